"""An upper bound on what any policy can collect in a DCP episode: the unlimited-energy bound.

Beyond the thesis. Issue 28 asks a general network for 1.10x the best navigator;
this yardstick says how much better than the navigators *any* policy could be on
the same episodes, so that a goal above the bound is known to be out of reach.

Why it bounds every policy. Apart from the risk draws, the DCP of section 4.3 is
deterministic and fully observed: given that the agent is still flying, its
state follows from its moves. So a policy's expected reward is at most that of
the best *path* from the start cell, and the best path visits the item cells in
some order, reaching each from the previous one along its safest route. The
bound drops the energy constraint (and the step cap): recharging only adds
cells, and so risk, to a path, and an unlimited budget allows every path a
budget allows. What remains is a tour problem on the item cells, solved exactly
by dynamic programming over the sets of collected cells.

The transition is :meth:`jaxdc.dcp.env.DCP.step_env`'s: the agent enters a cell,
is paid its item, and *then* draws the cell's risk. With ``q[u, v]`` the largest
probability of surviving the cells entered strictly between ``u`` and ``v`` on
any path (``v``'s own risk is drawn after its item is paid; ``q[u, u] = 1``:
``stay`` collects an item under the agent) and ``rho`` the risk map, an item cell
``u`` just collected leads to ``v`` with weight ``w[u, v] = (1 - rho[u]) q[u, v]``,
the start cell ``s`` (no risk is drawn at reset) with ``q[s, v]``, and

    ``V(S, u) = max(0, max_{v not in S} w[u, v] (r_v + V(S + v, v)))``,
    ``bound = max(0, max_v q[s, v] (r_v + V({v}, v)))``,

over the sets ``S`` of collected item cells. Any route that passes an item cell
on its way is one of these orders (it collects that item there), so no path does
better. With one item the bound is the probability of reaching it by the safest
route, which is the exact optimum of :mod:`jaxdc.dcp.exact.optimal` once the
budget covers that route (tests/dcp/exact/test_unlimited.py checks both).

The dynamic program holds ``2**m x m`` values for ``m`` item cells, so it is
limited to :data:`MAX_ITEM_CELLS` cells: an environment whose item count could
exceed it (``total_reward`` units fall on at most that many cells) is refused.
"""

from __future__ import annotations

import functools
import math
import numbers
from typing import Any, NamedTuple

import jax
import numpy as np

from jaxdc.core import grid, memory
from jaxdc.core.paths import adjacency
from jaxdc.core.rollout import initial_states
from jaxdc.core.validate import check_positive_int

#: The most item cells the dynamic program takes (``2**20 x 20`` float64 values, 168 MB).
MAX_ITEM_CELLS = 20
#: Rows of the subset table processed at once (the ``[rows, m, m]`` temporary stays in cache: about 6 MB).
_CHUNK = 2048


def reach_table(risk: Any) -> np.ndarray:
    """``q[u, v]`` (float64, ``[N*N, N*N]``, row-major cells): the largest probability of surviving the cells
    entered strictly between ``u`` and ``v`` on a path of 8-connected moves, ``q[u, u] = 1``.

    Floyd-Warshall on ``-log(1 - rho)`` of each entered cell (risk 1: probability 0, never NaN), then the
    last move into ``v`` from its cheapest neighbour, whose own risk is not paid. ``risk`` is checked as any
    user map (:func:`jaxdc.core.grid.validate_risk_map`) and read in float64."""
    grid.validate_risk_map(risk)
    rho = np.asarray(risk, np.float64)
    adj = adjacency(rho.shape[0])
    with np.errstate(divide="ignore"):
        enter = -np.log1p(-rho.reshape(-1))
    cost = np.where(adj, enter[None, :], np.inf)
    np.fill_diagonal(cost, 0.0)
    for k in range(cost.shape[0]):
        np.minimum(cost, cost[:, k:k + 1] + cost[k:k + 1, :], out=cost)
    before = np.min(np.where(adj[None, :, :], cost[:, :, None], np.inf), axis=1)
    q = np.exp(-before)
    np.fill_diagonal(q, 1.0)
    return q


@functools.lru_cache(maxsize=MAX_ITEM_CELLS + 1)
def _layers(m: int) -> tuple[np.ndarray, ...]:
    """The subsets of ``m`` cells grouped by size: ``layers[k]`` holds every bit set of ``k`` cells."""
    sets = np.arange(1 << m, dtype=np.int64)
    size = np.zeros(1 << m, dtype=np.int64)
    for b in range(m):
        size += (sets >> b) & 1
    order = np.argsort(size, kind="stable")
    bounds = np.searchsorted(size[order], np.arange(m + 2))
    return tuple(sets[order[bounds[k]:bounds[k + 1]]] for k in range(m + 1))


def tour_bound(q: np.ndarray, risk: Any, items: Any, start: int) -> float:
    """The unlimited-energy bound of one initial state: ``q`` from :func:`reach_table` of ``risk``, the item
    rewards ``items`` (``[N, N]`` or flat), the agent's flat start cell ``start``."""
    r_all = np.asarray(items, np.float64).reshape(-1)
    if q.shape != (r_all.size, r_all.size):
        raise ValueError(f"tour_bound needs q of shape {(r_all.size, r_all.size)} (reach_table of the map), "
                         f"got {q.shape}")
    if isinstance(start, bool) or not isinstance(start, numbers.Integral) or not 0 <= start < r_all.size:
        raise ValueError(f"start must be a flat cell index in [0, {r_all.size}), got {start!r}")
    if not np.all(np.isfinite(r_all)) or np.any(r_all < 0):
        raise ValueError(f"items must be finite rewards >= 0, got {r_all[~(np.isfinite(r_all) & (r_all >= 0))][0]}")
    cells = np.flatnonzero(r_all > 0)
    m = len(cells)
    if m == 0:
        return 0.0
    if m > MAX_ITEM_CELLS:
        raise ValueError(f"the unlimited-energy bound takes at most {MAX_ITEM_CELLS} item cells, got {m}")
    memory.check_fits(8 * m << m, f"the unlimited-energy bound's table of {m} item cells", "the item count")
    r = r_all[cells]
    survive = 1.0 - np.asarray(risk, np.float64).reshape(-1)[cells]
    w = survive[:, None] * q[np.ix_(cells, cells)]  # [u, v]: from item cell u (collected) to v
    bits = np.int64(1) << np.arange(m, dtype=np.int64)
    values = np.zeros((1 << m, m))  # V(S, u); every cell collected: 0
    layers = _layers(m)
    for k in range(m - 1, 0, -1):
        for lo in range(0, len(layers[k]), _CHUNK):
            sets = layers[k][lo:lo + _CHUNK]
            grown = sets[:, None] | bits[None, :]  # [rows, v]
            gain = np.where(grown != sets[:, None], r[None, :] + values[grown, np.arange(m)[None, :]], 0.0)
            values[sets] = np.max(gain[:, None, :] * w[None, :, :], axis=2)
    first = q[int(start), cells] * (r + values[bits, np.arange(m)])
    return float(max(0.0, np.max(first)))


#: :func:`jaxdc.core.rollout.initial_states`, compiled once per environment and episode count.
_initial_states = jax.jit(initial_states, static_argnums=(0, 3))


@functools.lru_cache(maxsize=64)
def _reach_table_of(risk_bytes: bytes, n: int) -> np.ndarray:
    return reach_table(np.frombuffer(risk_bytes, np.float64).reshape(n, n))


@functools.lru_cache(maxsize=1 << 15)
def _episode_bound(risk_bytes: bytes, items_bytes: bytes, start: int, n: int) -> float:
    """:func:`tour_bound` of one initial state, remembered: the budget does not change the bound, so a grid
    of budgets on one map and key solves each episode once."""
    risk = np.frombuffer(risk_bytes, np.float64).reshape(n, n)
    return tour_bound(_reach_table_of(risk_bytes, n), risk, np.frombuffer(items_bytes, np.float64), start)


class BoundEvaluation(NamedTuple):
    """The bound on each episode an evaluation with the same key plays, and their mean."""

    values: np.ndarray  # [episodes] float64
    mean: float
    se: float


def check_bound_fits(env) -> None:
    """``ValueError`` naming ``total_reward`` if an episode of ``env`` may hold more than
    :data:`MAX_ITEM_CELLS` item cells."""
    cells = min(int(env.total_reward), env.grid_size * env.grid_size)
    if cells > MAX_ITEM_CELLS:
        raise ValueError(f"total_reward must be <= {MAX_ITEM_CELLS} for the unlimited-energy bound (its units can "
                         f"fall on {cells} item cells, and the exact tour search holds 2**cells values), got "
                         f"{env.total_reward}")


def evaluate_bound(env, params, key, episodes: int = 10_000) -> BoundEvaluation:
    """The unlimited-energy bound on the ``episodes`` initial states that
    :func:`jaxdc.core.rollout.run_episodes` plays with ``key`` (the same episodes as
    :func:`jaxdc.dcp.evaluate.evaluate_heuristic` and ``evaluate_learned``), each on its own risk map."""
    check_bound_fits(env)
    env.check_params(params)
    episodes = check_positive_int("episodes", episodes)
    _, states, _ = _initial_states(env, params, key, episodes)
    risks = np.asarray(jax.vmap(env.risk_of, in_axes=(0, None))(states, params), np.float64)
    items = np.asarray(states.items, np.float64)
    starts = np.asarray(states.pos[:, 0] * env.grid_size + states.pos[:, 1])
    values = np.array([_episode_bound(risks[i].tobytes(), items[i].tobytes(), int(starts[i]), env.grid_size)
                       for i in range(episodes)])
    return BoundEvaluation(values, float(values.mean()), float(values.std() / math.sqrt(episodes)))


__all__ = ["MAX_ITEM_CELLS", "BoundEvaluation", "check_bound_fits", "evaluate_bound", "reach_table", "tour_bound"]
