"""The DCP's records (thesis section 4.3): how an episode ends, the numeric settings and the state.

:class:`EnvParams` holds what may differ across a ``vmap`` batch (built and validated by
:meth:`jaxdc.dcp.env.DCP.make_params`); :class:`EnvState` is everything one episode carries between steps, so
that the step stays a pure function (:mod:`jaxdc.dcp.env`). :mod:`jaxdc.dcp.env` re-exports the three.
"""

from __future__ import annotations

from typing import Any

import jax
from flax import struct

#: How an episode ended; ``info["outcome"]`` holds the index.
OUTCOMES = ("running", "risk", "energy", "cleared", "idle", "truncated")
RUNNING, RISK, ENERGY, CLEARED, IDLE, TRUNCATED = range(len(OUTCOMES))


@struct.dataclass
class EnvParams:
    """Numeric settings; every leaf may differ across a ``vmap`` batch.

    Build with :meth:`jaxdc.dcp.env.DCP.make_params`, which validates.
    """

    risk: jax.Array  # [N, N] float32, base risk 0
    init_energy: jax.Array  # float32; inf = no energy constraint (Table 4.1)
    max_energy: jax.Array  # float32; inf allowed
    max_steps: jax.Array  # int32 step cap (truncation)
    # Per-episode instances (beyond the thesis; :mod:`jaxdc.dcp.instances` builds them): ``None`` in the
    # thesis' setting, where ``risk`` and the energies above hold for every episode.
    maps: jax.Array | None = None  # [M, N, N] float32: the risk maps an episode draws from
    tables: Any = None  # PathTable of [M, N*N, N*N] leaves: each map's safest paths
    energy_range: jax.Array | None = None  # [2] float32: the maximum energy is an int drawn from [low, high]
    # float32 power-law tilt of that draw (core.energy.draw_max_energy; None: uniform over the integers)
    energy_tilt: jax.Array | None = None
    init_fraction: jax.Array | None = None  # float32: initial energy = round(init_fraction * maximum), >= 1


@struct.dataclass
class EnvState:
    pos: jax.Array  # [2] int32 (row, col)
    energy: jax.Array  # float32
    items: jax.Array  # [N, N] float32 reward per cell
    time: jax.Array  # int32 steps taken in this episode
    outcome: jax.Array  # int32 index into OUTCOMES
    ep_reward: jax.Array  # float32 reward collected so far
    ep_energy: jax.Array  # int32 energy consumed so far (see ENERGY_METRICS)
    rank: jax.Array  # [N, N] int32 position of each cell in the item list (ties; see ITEM_ORDERS)
    map_id: jax.Array | None = None  # int32 index into params.maps (per-episode instances only)
    max_energy: jax.Array | None = None  # float32 this episode's maximum energy (per-episode instances only)
