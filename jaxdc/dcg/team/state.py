"""The team DCG's state and its one-collector views (the thesis' conclusion to chapter 5, on section 5.3).

The thesis names its next step for the game: "generalizing the game to one with multiple data-collecting
agents, so that the agents can cooperate to collect data more efficiently under the influence of the
opponent". :class:`TeamState` holds ``k`` collectors and ``m`` opponents stacked on a leading axis; the
rules are those of section 5.3 applied to everyone at once (:mod:`jaxdc.dcg.team.env`).

The DCG's code is reused, not copied: an opponent strategy, the observation mixin and the energy rule
all see the game through :func:`collector_view`, a one-collector :class:`jaxdc.dcg.env.EnvState` of
collector ``i`` and opponent ``j``. With ``k = m = 1`` the view *is* the DCG's state.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from jaxdc.dcg.opponents import OpponentState
from jaxdc.dcg.types import RUNNING, EnvState

#: The largest team (the constructor refuses more; issue 29: 1-4 collectors).
MAX_COLLECTORS = 4
#: The most opponents (the constructor refuses more).
MAX_OPPONENTS = 4
#: Whom a fog strategy (``with_fog``, ``double_blind``) chases in a team (docs/ambiguities.md):
#: ``"visible"`` -- the nearest active collector outside the fog, staying when every active collector is in
#: it; ``"nearest"`` -- the nearest active collector, staying when it is in the fog.
FOG_TARGETS = ("visible", "nearest")
#: How a chaser breaks a tie between equally near collectors: ``"index"`` -- the lowest collector index.
TARGET_TIES = ("index",)


@struct.dataclass
class TeamState:
    """The game of ``k`` collectors and ``m`` opponents; build it with ``DCGTeam.reset``."""

    pos: jax.Array  # [k, 2] int32 collector cells
    energy: jax.Array  # [k] float32
    collector_outcome: jax.Array  # [k] int32 index into OUTCOMES: running (active), caught or energy
    items: jax.Array  # [N, N] float32 reward per cell (shared)
    opponent: OpponentState  # every leaf stacked [m, ...]
    strategy: jax.Array  # [m] int32 index into DCGTeam.strategies
    history: jax.Array  # [k, N, N, H] float32: each collector's observed agent planes M_{t-1} .. M_{t-H}
    time: jax.Array  # int32 steps taken in this episode
    outcome: jax.Array  # int32 index into OUTCOMES (the episode's)
    ep_reward: jax.Array  # float32 team reward so far
    ep_energy: jax.Array  # int32 energy consumed so far, summed over the collectors
    max_energy: jax.Array | None = None  # float32 this episode's maximum energy (with params.energy_range only)

    @property
    def active(self) -> jax.Array:
        """``[k]`` bool: the collectors not yet disabled."""
        return self.collector_outcome == RUNNING


def opponent_of(state: TeamState, j: Any) -> OpponentState:
    """Opponent ``j``'s :class:`~jaxdc.dcg.opponents.OpponentState` (unstacked)."""
    return jax.tree_util.tree_map(lambda x: x[j], state.opponent)


def collector_view(state: TeamState, i: Any, j: Any = 0) -> EnvState:
    """The one-collector DCG state of collector ``i`` facing opponent ``j`` (both may be traced)."""
    return EnvState(
        pos=state.pos[i], energy=state.energy[i], items=state.items, opponent=opponent_of(state, j),
        strategy=state.strategy[j], history=state.history[i], time=state.time,
        outcome=state.collector_outcome[i], ep_reward=state.ep_reward, ep_energy=state.ep_energy,
        max_energy=state.max_energy,
    )


def views(state: TeamState) -> EnvState:
    """Every collector's view of every opponent, stacked ``[k, m, ...]``."""
    k, m = state.pos.shape[0], state.strategy.shape[0]
    ii, jj = jnp.meshgrid(jnp.arange(k), jnp.arange(m), indexing="ij")
    return jax.vmap(jax.vmap(lambda i, j: collector_view(state, i, j)))(ii, jj)
