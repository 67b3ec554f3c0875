"""All-pairs safest paths on the 8-connected grid (section 4.4.1, Fig. 4.2).

Section 4.4.1 uses Dijkstra's algorithm "to compute the *safest path* from
any cell to any other cell on the grid"; Fig. 4.2b shows the resulting
*success probabilities*, and Algorithm 7 (LPG) reads both the probability
``P_{x,y}(x', y')`` and "the a that follows the safest path" from them. This
module computes, for one ``N x N`` risk map, the full table over all
``N^2 x N^2`` (source, target) pairs:

* ``success[c, b]`` -- success probability of the safest path from ``c`` to ``b``;
* ``next_action[c, b]`` -- the first action of that path (index into
  :data:`jaxdc.core.grid.ACTIONS`);
* ``steps[c, b]`` -- its number of moves.

Cells are flattened row-major (``index = row * N + col``). The moves are the 8
non-stay actions of :data:`jaxdc.core.grid.DELTAS_NP`, clipped per axis at the
border exactly as :func:`jaxdc.core.grid.move`; a clipped move that lands on
its own cell is a self-loop and is ignored, so the successors of a cell are its
Chebyshev-distance-1 neighbours (and the graph is symmetric).

Risk convention (``path_risk``; the thesis does not say which cells of a path
count): a path ``c0 = c, c1, ..., ck = b`` succeeds with probability
``prod (1 - risk)`` over

* ``"departed"`` -- the cells the agent leaves, ``c0 .. c_{k-1}``;
* ``"entered"``  -- the cells the agent enters, ``c1 .. ck``.

Both are encoded as directed edge weights ``w(u -> v) = -log1p(-risk[u])``
(departed) or ``-log1p(-risk[v])`` (entered), so the safest path is the
shortest path and ``success = exp(-cost)``. Risk 1 gives an infinite weight,
i.e. probability 0 (never NaN).

Ties. Many paths are usually equally safe (every zero-risk cell, every uniform
region). Among the paths whose cost is within the tolerance of the optimum we
take the one with the **fewest moves**, then the **lowest action index** at
each step. The tolerance is absolute on the log-cost, ``tie_tol * (1 + cost)``
-- i.e. ``tie_tol`` relative on the probability, widened with the cost so that
float32 round-off on long, costly paths never breaks a genuine tie. Precisely,
with ``q(c) = min_a w(c -> c'_a) + cost(c'_a)``, a move ``a`` is *tight* when
``w(c -> c'_a) + cost(c'_a) <= q(c) + tie_tol * (1 + q(c))``; ``steps`` is the
BFS distance to ``b`` over tight moves and ``next_action`` is the lowest tight
action whose successor has ``steps[c', b] = steps[c, b] - 1``. Hence following
``next_action`` reaches ``b`` in exactly ``steps`` moves. For pairs with
probability 0 (every path crosses a risk-1 cell) all moves of an infinite-cost
cell are tight, so the "safest" path there is a fewest-moves path.

Algorithm. For each target ``b`` a reverse Dijkstra from ``b`` runs inside
:func:`jax.lax.while_loop` (one settled cell per iteration, popped by the
lexicographic key (cost, steps, index); its up to 8 predecessors are relaxed,
with ties on the cost resolved to the fewer steps). A short vectorised sweep
then makes ``steps`` exactly consistent with the tight-move definition above
(normally 0-1 extra passes; it only matters for float near-ties across
zero-risk cells), and ``next_action`` is read off the 8 neighbours. Everything
is vmapped over the ``N^2`` targets, jittable and vmappable over a batch of
risk maps.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxdc.core import grid, memory

#: The two readings of which cells' risk a path pays (see module docstring).
PATH_RISK: tuple[str, ...] = ("departed", "entered")

_BIG_STEPS = 1 << 29  # "not reached yet"; adding N^2 to it never overflows int32


@struct.dataclass
class PathTable:
    """All-pairs safest paths of one risk map (section 4.4.1, Fig. 4.2b).

    All fields are indexed ``[source, target]`` with row-major flat cells.

    Attributes:
        success: ``[N*N, N*N]`` float32, success probability of the safest path
            (1.0 on the diagonal, 0.0 where every path crosses a risk-1 cell).
        next_action: ``[N*N, N*N]`` int32, first action (index into
            :data:`jaxdc.core.grid.ACTIONS`) along that path; 0 (stay) on the diagonal.
        steps: ``[N*N, N*N]`` int32, number of moves of that path (fewest
            moves among the equally safe paths).
    """

    success: jax.Array
    next_action: jax.Array
    steps: jax.Array


def _neighbour_table(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Static tables: successor ``[N*N, 8]`` of each move, its validity, and adjacency ``[N*N, N*N]``."""
    r, c = np.divmod(np.arange(n * n), n)
    d = grid.DELTAS_NP[1:]  # the 8 moves, actions 1..8
    nr = np.clip(r[:, None] + d[None, :, 0], 0, n - 1)
    nc = np.clip(c[:, None] + d[None, :, 1], 0, n - 1)
    succ = (nr * n + nc).astype(np.int32)
    valid = succ != np.arange(n * n)[:, None]
    adj = np.zeros((n * n, n * n), dtype=bool)
    rows = np.repeat(np.arange(n * n), 8)
    adj[rows[valid.ravel()], succ.ravel()[valid.ravel()]] = True
    return succ, valid, adj


def successors(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``([N*N, 8] int32, [N*N, 8] bool)``: the cell each non-stay move (actions 1..8) leads to, clipped at the border
    as :func:`jaxdc.core.grid.move`, and whether that is another cell (a clipped move onto its own cell is not)."""
    succ, valid, _ = _neighbour_table(n)
    return succ, valid


def adjacency(n: int) -> np.ndarray:
    """``[N*N, N*N]`` bool: the cells one non-stay move apart (Chebyshev distance 1), row-major."""
    return _neighbour_table(n)[2]


def _close(a, b, tie_tol):
    """``a`` and ``b`` (costs, possibly inf) are equal within ``tie_tol * (1 + min)``; NaN-free."""
    lo = jnp.minimum(a, b)
    tol = jnp.where(jnp.isfinite(lo), tie_tol * (1.0 + lo), 0.0)
    diff = jnp.where(a == b, 0.0, jnp.abs(a - b))  # inf - inf never reaches a comparison as NaN
    return (a == b) | (diff <= tol)


def _single_target(lw, b, succ, valid, adj, departed: bool, tie_tol):
    """Reverse Dijkstra from target ``b``: cost, steps and next action of every source cell.

    Returns ``(cost [M], next_action [M], steps [M])`` with ``M = N*N``.
    """
    m = lw.shape[0]
    idx = jnp.arange(m)
    cost0 = jnp.where(idx == b, 0.0, jnp.inf).astype(jnp.float32)
    steps0 = jnp.where(idx == b, 0, _BIG_STEPS).astype(jnp.int32)
    settled0 = jnp.zeros(m, dtype=bool)

    def cond(state):
        _, _, _, k = state
        return k < m

    def body(state):
        cost, steps, settled, k = state
        # Pop the unsettled cell with the smallest (cost, steps, index) key.
        ucost = jnp.where(settled, jnp.inf, cost)
        best = jnp.min(ucost)
        cand = (~settled) & (ucost == best)
        v = jnp.argmin(jnp.where(cand, steps, jnp.iinfo(jnp.int32).max))
        settled = settled.at[v].set(True)
        # Relax its predecessors u (u -> v is a move; the grid graph is symmetric).
        w = lw if departed else jnp.broadcast_to(lw[v], (m,))
        ncost = cost[v] + w
        nsteps = steps[v] + 1
        pred = adj[v] & (~settled)
        tie = _close(ncost, cost, tie_tol)
        better = (ncost < cost) & ~tie
        new_cost = jnp.where(better, ncost, jnp.where(tie, jnp.minimum(cost, ncost), cost))
        new_steps = jnp.where(better, nsteps, jnp.where(tie, jnp.minimum(steps, nsteps), steps))
        cost = jnp.where(pred, new_cost, cost)
        steps = jnp.where(pred, new_steps, steps)
        return cost, steps, settled, k + 1

    cost, steps, _, _ = jax.lax.while_loop(cond, body, (cost0, steps0, settled0, jnp.int32(0)))

    # Tight moves of every cell (static structure, so computed once).
    w_move = (lw[:, None] if departed else lw[succ]) * jnp.ones_like(succ, dtype=lw.dtype)
    move_cost = jnp.where(valid, w_move + cost[succ], jnp.inf)  # [M, 8]
    q = jnp.min(move_cost, axis=1, keepdims=True)
    tight = valid & ((move_cost <= q) | _close(move_cost, q, tie_tol))
    is_b = idx == b

    def sweep(s):
        cand = jnp.where(tight, s[succ], _BIG_STEPS)
        return jnp.where(is_b, 0, jnp.minimum(jnp.min(cand, axis=1) + 1, _BIG_STEPS))

    def s_cond(state):
        _, changed, k = state
        return changed & (k <= m)

    def s_body(state):
        s, _, k = state
        s_new = sweep(s)
        return s_new, jnp.any(s_new != s), k + 1

    steps, _, _ = jax.lax.while_loop(s_cond, s_body, (steps, jnp.bool_(True), jnp.int32(0)))

    cand = jnp.where(tight, steps[succ], _BIG_STEPS)
    action = (jnp.argmin(cand, axis=1) + 1).astype(jnp.int32)  # lowest action index on ties
    action = jnp.where(is_b, grid.STAY, action)
    return cost, action, steps


#: Peak bytes per (source, target) pair while the table is built (the vmapped searches and the three
#: ``[N^2, N^2]`` outputs; about 100 measured on the CPU at N = 40): the table grows as ``N^4``.
BYTES_PER_PAIR = 128


def _check_path_risk(path_risk) -> bool:
    if path_risk not in PATH_RISK:
        raise ValueError(f"path_risk must be one of {PATH_RISK}, got {path_risk!r}")
    return path_risk == "departed"


def safest_paths(risk: Any, path_risk: str = "departed", tie_tol: float = 1e-6) -> PathTable:
    """All-pairs safest paths of an ``N x N`` risk map (section 4.4.1, Fig. 4.2b).

    Runs a reverse Dijkstra per target inside :func:`jax.lax.while_loop`,
    vmapped over all ``N^2`` targets; see the module docstring for the path
    model, the ``path_risk`` conventions and the tie-breaking rules.

    Args:
        risk: ``[N, N]`` risk map (values in ``[0, 1]``; clipped to it). May
            be traced; ``jax.vmap`` over a leading batch axis works.
        path_risk: ``"departed"`` (pay the risk of every cell left) or
            ``"entered"`` (pay the risk of every cell entered). Static under jit.
        tie_tol: relative tolerance on the success probability below which two
            paths count as equally safe (then the fewest moves, then the lowest
            action index wins).

    Returns:
        A :class:`PathTable` of ``[N*N, N*N]`` arrays indexed ``[source, target]``.
    """
    departed = _check_path_risk(path_risk)
    if jnp.ndim(risk) != 2 or jnp.shape(risk)[0] != jnp.shape(risk)[1]:
        raise ValueError(f"risk map must be a square N x N array, got shape {jnp.shape(risk)}")
    n = grid.check_grid_size(int(jnp.shape(risk)[0]))
    memory.check_fits(BYTES_PER_PAIR * n**4, f"the safest-path table of a {n} x {n} grid", "the grid size")
    # Jitted internally so that eager calls compile once per shape instead of
    # dispatching the while_loops op by op; inlined under an outer jit/vmap.
    return _safest_paths(risk, departed, tie_tol)


@jax.jit(static_argnames=("departed",))
def _safest_paths(risk, departed: bool, tie_tol) -> PathTable:
    n = risk.shape[0]
    succ_np, valid_np, adj_np = _neighbour_table(n)
    succ, valid, adj = jnp.asarray(succ_np), jnp.asarray(valid_np), jnp.asarray(adj_np)

    r = jnp.clip(jnp.asarray(risk, dtype=jnp.float32).reshape(-1), 0.0, 1.0)
    lw = -jnp.log1p(-r)  # risk 1 -> +inf, never NaN
    targets = jnp.arange(n * n)
    cost, action, steps = jax.vmap(
        lambda b: _single_target(lw, b, succ, valid, adj, departed, tie_tol)
    )(targets)
    # vmap gives [target, source]; the table is [source, target].
    return PathTable(success=jnp.exp(-cost).T, next_action=action.T, steps=steps.T)


def path_to(table: PathTable, src: Any, dst: Any) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``(success, next_action, steps)`` of the safest path from flat cell ``src`` to ``dst``."""
    return table.success[src, dst], table.next_action[src, dst], table.steps[src, dst]
