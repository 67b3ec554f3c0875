"""Whom each opponent chases in the team DCG, and the opponents' simultaneous move (step 1 of section 5.3).

The thesis' strategies (section 5.5.1, 5.5.7) chase "the collector". With several collectors (the
team extension named in the thesis' conclusion to chapter 5), opponent ``j`` chases its *target*: the
nearest active collector, the distance counted in moves of the strategy's action set (Manhattan for
``restricted``, Chebyshev otherwise), ties to the lowest collector index (``target_tie="index"``). The
fog strategies (``with_fog``, ``double_blind``) read ``fog_target`` (:data:`~jaxdc.dcg.team.state.FOG_TARGETS`):
``"visible"`` chases the nearest active collector outside the fog, ``"nearest"`` the nearest one; either
stays when its target is in the fog. ``patrol`` ignores the collectors. Disabled collectors are never
targets. With one collector every reading is the thesis' rule.

The strategy itself is the DCG's (:meth:`jaxdc.dcg.env.DCG.opponent_move`), called on the one-collector
view of its target (:func:`jaxdc.dcg.team.state.collector_view`); all opponents move from the pre-step
state, opponent ``j`` with the step key folded with ``j`` (``j = 0``: the step key itself, as in the DCG).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core import grid
from jaxdc.dcg import opponents as opp_lib
from jaxdc.dcg.opponents import OpponentState
from jaxdc.dcg.team.state import TeamState, collector_view

if TYPE_CHECKING:
    from jaxdc.dcg.team.env import DCGTeam

#: Strategies whose chase counts Manhattan moves (the restricted action set of section 5.5.1).
MANHATTAN_STRATEGIES = ("restricted",)


def strategy_flags(strategies: tuple[opp_lib.Strategy, ...]) -> tuple[np.ndarray, np.ndarray]:
    """``(manhattan, fog)``: per strategy of the set, whether its distance is Manhattan and whether it reads
    the fog (one of :data:`~jaxdc.dcg.opponents.FOG_STRATEGIES` or a fog-hiding one)."""
    manhattan = np.asarray([s.name in MANHATTAN_STRATEGIES for s in strategies])
    fog = np.asarray([s.name in opp_lib.FOG_STRATEGIES or s.hides_in_fog for s in strategies])
    return manhattan, fog


def target_of(env: DCGTeam, state: TeamState, j: Any) -> jax.Array:
    """The index of the collector opponent ``j`` chases (see the module docs); 0 when none is active."""
    manhattan, fog = strategy_flags(env.single._strategies)
    opp_pos = state.opponent.pos[j]
    s = state.strategy[j]
    d = jnp.where(jnp.asarray(manhattan)[s], grid.manhattan(state.pos, opp_pos), grid.chebyshev(state.pos, opp_pos))
    active = state.active
    candidates = active
    if env.fog_target == "visible":
        visible = active & ~opp_lib.in_fog(state.pos)
        candidates = jnp.where(jnp.asarray(fog)[s] & jnp.any(visible), visible, active)
    big = jnp.int32(1 << 20)
    return jnp.argmin(jnp.where(candidates, d, big)).astype(jnp.int32)  # argmin: the lowest index on a tie


def opponent_keys(key: jax.Array, m: int) -> jax.Array:
    """The step keys of ``m`` opponents: the step key for the first, ``fold_in(key, j)`` for opponent ``j``."""
    return jnp.stack([key] + [jax.random.fold_in(key, j) for j in range(1, m)])


def opponents_move(env: DCGTeam, key: jax.Array, state: TeamState, params: Any) -> tuple[jax.Array, OpponentState]:
    """Every opponent's action ``o_t`` ``[m]`` and their new stacked state, all from the pre-step ``state``."""
    m = env.opponents

    def one(k, j):
        view = collector_view(state, target_of(env, state, j), j)
        return env.single.opponent_move(k, view, params)

    actions, opps = jax.vmap(one)(opponent_keys(key, m), jnp.arange(m))
    return actions, opps


__all__ = ["MANHATTAN_STRATEGIES", "strategy_flags", "target_of", "opponent_keys", "opponents_move"]
