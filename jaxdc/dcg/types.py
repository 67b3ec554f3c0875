"""The DCG's records (thesis section 5.3): how an episode ends, the numeric settings and the state.

:class:`EnvParams` holds what may differ across a ``vmap`` batch (built and validated by
:meth:`jaxdc.dcg.env.DCG.make_params`); :class:`EnvState` is everything one game carries between steps, so that
the step stays a pure function (:mod:`jaxdc.dcg.env`). :mod:`jaxdc.dcg.env` re-exports the three.
"""

from __future__ import annotations

import jax
from flax import struct

from jaxdc.dcg.opponents import OpponentState

#: How an episode ended; ``info["outcome"]`` holds the index.
OUTCOMES = ("running", "caught", "energy", "cleared", "truncated")
RUNNING, CAUGHT, ENERGY, CLEARED, TRUNCATED = range(len(OUTCOMES))


@struct.dataclass
class EnvParams:
    """Numeric settings; every leaf may differ across a ``vmap`` batch.

    Build with :meth:`jaxdc.dcg.env.DCG.make_params`, which validates.
    """

    max_energy: jax.Array  # float32; the collector starts with it and refills to it in the base
    max_steps: jax.Array  # int32 step cap (truncation)
    chase_tie: jax.Array  # int32 index into opponents.CHASE_TIES
    # Beyond the thesis: [2] float32, each episode's maximum energy is an int drawn from [low, high] (None: max_energy)
    energy_range: jax.Array | None = None
    # Beyond the thesis: float32 power-law tilt of that draw (core.energy.draw_max_energy; None: uniform)
    energy_tilt: jax.Array | None = None


@struct.dataclass
class EnvState:
    pos: jax.Array  # [2] int32 collector (row, col)
    energy: jax.Array  # float32
    items: jax.Array  # [N, N] float32 reward per cell
    opponent: OpponentState
    strategy: jax.Array  # int32 index into DCG.strategies (this episode's strategy)
    history: jax.Array  # [N, N, k] float32: observed agent planes M_{t-1} .. M_{t-k}
    time: jax.Array  # int32 steps taken in this episode
    outcome: jax.Array  # int32 index into OUTCOMES
    ep_reward: jax.Array  # float32
    ep_energy: jax.Array  # int32 energy consumed so far (see ENERGY_METRICS)
    max_energy: jax.Array | None = None  # float32 this episode's maximum energy (with params.energy_range only)
