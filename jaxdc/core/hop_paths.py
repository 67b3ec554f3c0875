"""Safest paths of at most ``h`` moves: routes that fit an energy budget (beyond the thesis).

Section 4.4.1's safest path ignores the energy. When it is longer than the energy allows, Algorithm 9 turns
home, and if it does not fit even a full battery the navigators never take it. A policy that must reach a cell
within ``h`` moves needs the safest path *among those of at most* ``h`` *moves* (a hop-constrained shortest path),
which may be a riskier shortcut, or the safe detour when it fits. For one target ``b`` it is a Bellman-Ford
recursion over the number of moves on the log-costs of :mod:`jaxdc.core.paths`::

    C_0(c) = 0 if c = b, else inf
    C_k(c) = min(C_{k-1}(c),  min_a  w(c, a) + eps + C_{k-1}(c'_a))

where ``c'_a`` is the cell that move ``a`` (one of the 8 non-stay moves, clipped at the border as
:func:`jaxdc.core.grid.move`) leads to, and ``w(c, a) = -log P(c -> c'_a)`` is the cost of that one move. The
move costs are read from the safest-path table itself: one move is always the safest path between two neighbours,
under either ``path_risk`` reading, so ``table.success[c, c'_a]`` is exactly the move's success probability and
the routes here pay the same cells as the table's. ``eps`` (:data:`MOVE_EPS`, on the log-cost) makes the fewest
moves win among equally safe routes, as the table's tie rule does; it changes a route's success probability by
at most ``eps`` per move. The first move of the route from ``c`` within ``h`` moves is the lowest action ``a``
that minimises ``w(c, a) + eps + C_{h-1}(c'_a)``.

The recursion runs ``min(h, N^2) - 1`` rounds (no simple path has more than ``N^2 - 1`` moves), each over
``N^2 x 8`` moves, inside :func:`jax.lax.while_loop` (under ``vmap``, as many rounds as the largest budget of the
batch needs). Pure and jittable.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from jaxdc.core import grid
from jaxdc.core.paths import PathTable, successors

#: Cost added per move (log-cost), so that the fewest moves win among equally safe routes.
MOVE_EPS = 1e-5


@struct.dataclass
class Route:
    """The first move of the safest route within a move budget.

    Attributes:
      action: int32, the first action (index into :data:`jaxdc.core.grid.ACTIONS`); ``STAY`` at the target, and
        also where no route fits (then ``feasible`` is False).
      steps: int32, the number of moves of that route (0 at the target or where none fits).
      success: float32, its success probability (1 at the target, 0 where none fits).
      feasible: bool, whether a route of at most ``moves`` moves reaches the target.
    """

    action: jax.Array
    steps: jax.Array
    success: jax.Array
    feasible: jax.Array


def safest_within(table: PathTable, src: Any, dst: Any, moves: Any) -> Route:
    """The safest route from flat cell ``src`` to flat cell ``dst`` with at most ``moves`` moves (see the module
    docstring), on the grid of ``table``. ``moves`` is a traced integer; below 0 it counts as 0."""
    m = table.success.shape[0]
    n = int(round(m**0.5))
    succ_np, valid_np = successors(n)
    succ, valid = jnp.asarray(succ_np), jnp.asarray(valid_np)
    move_p = jnp.take_along_axis(table.success, succ, axis=1)  # [M, 8]: success of each single move
    w = jnp.where(valid & (move_p > 0), -jnp.log(jnp.maximum(move_p, 1e-38)) + MOVE_EPS, jnp.inf)
    idx = jnp.arange(m)
    cost0 = jnp.where(idx == dst, 0.0, jnp.inf).astype(jnp.float32)
    steps0 = jnp.zeros(m, jnp.int32)
    budget = jnp.clip(jnp.asarray(moves, jnp.int32), 0, m)

    def relax(carry):
        cost, steps, k = carry
        via = w + cost[succ]  # [M, 8]
        best = jnp.argmin(via, axis=1)
        new_cost = jnp.take_along_axis(via, best[:, None], axis=1)[:, 0]
        better = new_cost < cost
        return jnp.where(better, new_cost, cost), jnp.where(better, steps[succ[idx, best]] + 1, steps), k + 1

    rounds = jnp.minimum(budget - 1, m - 1)  # C_{h-1}; no simple path has more than N^2 - 1 moves
    cost, steps, _ = jax.lax.while_loop(lambda c: c[2] < rounds, relax, (cost0, steps0, jnp.int32(0)))
    via = w[src] + cost[succ[src]]  # [8]: each first move, then the best route of at most moves - 1 moves
    best = jnp.argmin(via)
    at_target = src == dst
    feasible = at_target | (jnp.isfinite(via[best]) & (budget >= 1))
    action = jnp.where(at_target | ~feasible, grid.STAY, best + 1).astype(jnp.int32)
    n_steps = jnp.where(at_target | ~feasible, 0, steps[succ[src, best]] + 1).astype(jnp.int32)
    success = jnp.where(at_target, 1.0, jnp.where(feasible, jnp.exp(-(via[best] - MOVE_EPS * n_steps)), 0.0))
    return Route(action=action, steps=n_steps, success=success.astype(jnp.float32), feasible=feasible)


__all__ = ["MOVE_EPS", "Route", "safest_within"]
