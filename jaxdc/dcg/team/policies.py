"""Team policies that need no team training: copies of a one-collector policy, and a scripted team (issue 29).

The thesis' conclusion to chapter 5 proposes collectors that "cooperate to collect data more efficiently
under the influence of the opponent". Two yardsticks say what a trained team must beat:

* :func:`copies` -- ``k`` copies of a one-collector policy (e.g. a shipped DCG network), each playing from
  its own seat with the one-collector observation (``DCGTeam(teammates=False)``): no cooperation beyond
  sharing the items.
* :func:`greedy_split` -- scripted collectors that split the items: collector ``i`` heads for the nearest
  remaining item cell (Chebyshev distance, ties to the first cell in row-major order) that no
  lower-indexed collector is heading for (any remaining cell when every one is taken), and turns home
  when the energy left would not bring it back to the base after the move (the energy rule of section
  5.3: a step outside the base costs one unit, the base refills). It ignores the opponent.

Both are ``policy(key, obs, state) -> actions [k]`` as :func:`jaxdc.core.rollout.run_episodes` plays them.
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp

from jaxdc.core import grid
from jaxdc.dcg.team.state import TeamState, collector_view
from jaxdc.dcg.team.targeting import opponent_keys

#: ``policy(key, obs, state) -> action``: a one-collector policy (``obs`` one collector's, ``state`` a DCG state).
SinglePolicy = Callable[[jax.Array, jax.Array, object], jax.Array]
TeamPolicy = Callable[[jax.Array, jax.Array, TeamState], jax.Array]


def copies(policy: SinglePolicy, collectors: int) -> TeamPolicy:
    """``collectors`` copies of ``policy``: collector ``i`` acts on ``obs[i]`` and its one-collector view of the
    game (:func:`jaxdc.dcg.team.state.collector_view`, facing the first opponent). Collector 0 acts with the step
    key itself and collector ``i`` with ``fold_in(key, i)`` (as the opponents' keys are drawn), so one copy plays
    exactly the games the one-collector evaluation plays with the same key."""

    def team(key: jax.Array, obs: jax.Array, state: TeamState) -> jax.Array:
        keys = opponent_keys(key, collectors)

        def one(i, k):
            return policy(k, obs[i], collector_view(state, i))

        return jax.vmap(one)(jnp.arange(collectors), keys).astype(jnp.int32)

    return team


def greedy_split(grid_size: int, collectors: int) -> TeamPolicy:
    """The scripted team of the module docs on an ``grid_size x grid_size`` grid (it reads the state, not ``obs``)."""
    n = grid_size
    cells = jnp.stack(jnp.divmod(jnp.arange(n * n), n), -1)  # [C, 2] row-major
    far = jnp.int32(4 * n)

    def team(key: jax.Array, obs: jax.Array, state: TeamState) -> jax.Array:
        has_item = state.items.reshape(-1) > 0

        def choose(taken, i):
            d = grid.chebyshev(state.pos[i], cells)  # [C]
            free = has_item & ~taken
            pick = jnp.argmin(jnp.where(jnp.where(free.any(), free, has_item), d, far))
            target = jnp.where(has_item.any(), cells[pick], jnp.zeros(2, jnp.int32))
            step = grid.shortest_move(state.pos[i], target, n)
            after = grid.move(state.pos[i], step, n)
            # after the move the energy is one less (outside the base); it must still reach the base from there
            stranded = (state.energy[i] - 1.0 < grid.chebyshev(after, jnp.zeros(2, jnp.int32))) & ~jnp.all(after == 0)
            home = grid.shortest_move(state.pos[i], jnp.zeros(2, jnp.int32), n)
            action = jnp.where(stranded, home, step)
            return taken.at[pick].set(taken[pick] | has_item[pick]), action

        _, actions = jax.lax.scan(choose, jnp.zeros(n * n, bool), jnp.arange(collectors))
        return actions.astype(jnp.int32)

    return team
