"""The exact full-information bound of the one-item DCG over all start states (section 5.5.5, Fig. 5.10).

Section 5.5.5 plays the game of section 5.3 with one item of reward one in the
*reward area* (the bottom-right ``s x s`` square, Fig. 5.10). Give the
collector everything the networks have to infer -- the opponent's strategy and
its hidden state (patrol start, far end and direction) -- and the game becomes
a one-player problem small enough to solve exactly. Its value is an upper
bound on the expected episode reward of *any* collector, so a network above it
means a bug.

The episode reward of a one-item game is 1 if the item is collected and 0
otherwise, so the bound is the (undiscounted) probability of collecting it
before the episode ends: disabled (caught or out of energy) or truncated by the
step cap ``max_steps`` (a collection on the last step counts, as in the env).

With a deterministic opponent (the thesis' strategies with ``chase_tie``
``"straight"`` or ``"order"``) and the opponent's state known, the game is
deterministic, so the optimum is a shortest-path problem: the item in cell
``i`` can be collected iff some legal trajectory reaches it within
``max_steps`` steps. :func:`solve` finds, by one breadth-first search per
strategy over the states ``(initial opponent class, collector cell, energy,
opponent state)``, the earliest step at which every cell can be entered legally
-- for all item cells at once, because the item changes nothing before it is
collected -- and the open-loop action plan that does it. The dynamic programme
is this search's Bellman recursion ``c(s) = 1 + min_a c(s')`` on the
earliest-arrival times; a state reached earlier is never worse, because the
rules are time-homogeneous and the step cap only bounds the total.

The transition is that of :meth:`jaxdc.dcg.env.DCG.step_env` (section 5.3):

1. the opponent moves (:meth:`~jaxdc.dcg.env.DCG.opponent_move`, the env's own strategy
   functions, tabulated over all opponent states and collector cells); if it
   lands on the collector, the collector is disabled without moving;
2. the collector moves (clipped per axis) and collects the item in its new cell;
3. if it ends on the opponent's cell it is disabled (the item of step 2 counts
   iff ``reward_when_caught``);
4. its energy refills in the base, else drops by one; 0 outside the base disables it.

Opponent states ``(pos, home, target, phase)`` reachable from the reset
distribution are merged when they behave identically (Moore partition
refinement on the tabulated transitions, the observable being the position;
:mod:`jaxdc.dcg.exact.machine`), so a chasing opponent is just its cell and a
patrol its place on its cycle.

:func:`full_information_bound` averages over the reset distribution of
:meth:`~jaxdc.dcg.env.DCG.reset_env` (item uniform over the reward area, opponent start and
patrol end as the env draws them, strategy uniform over ``env.strategies``);
:func:`optimal_policy` replays the plans in the real env through
:func:`jaxdc.core.rollout.run_episodes`.
"""

from __future__ import annotations

import math
import time as _time
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from jaxdc.core import grid
from jaxdc.core.memory import check_fits
from jaxdc.dcg.exact.machine import (
    MAX_GRID_SIZE,
    captures,
    check_params,
    local_machines,
    opponent_machine,
    reset_pairs,
    successors,
)

#: Earliest-collection step of an item that cannot be collected within the step cap.
NEVER = np.iinfo(np.int32).max


class Solution(NamedTuple):
    """The solved single-item DCG with full information (section 5.5.5 setting).

    ``steps[s, b, i]``: the fewest steps in which the collector can collect an
    item in cell ``i`` (row-major flat index) against strategy ``s`` (index
    into ``strategies``) from the reset state whose opponent is in initial
    class ``b``; :data:`NEVER` if it cannot within ``max_steps`` (padding
    classes are :data:`NEVER` too). ``init_class[s, home, target]``: the class
    of the reset opponent state ``(pos=home, home, target, phase=0)`` (flat
    cells), -1 where the reset never draws that pair. ``start_weight[home,
    target]``: the probability of that pair at reset. ``plans[s, i, b, t]``:
    the action at step ``t + 1`` of a fastest collecting trajectory (0 past
    its end or where the item cannot be collected).
    """

    steps: np.ndarray  # [S, B, N*N] int32
    init_class: np.ndarray  # [S, N*N, N*N] int32
    start_weight: np.ndarray  # [N*N, N*N] float64
    plans: np.ndarray  # [S, N*N, B, L] int8
    strategies: tuple
    grid_size: int
    max_energy: float
    max_steps: int
    opponent_classes: tuple  # number of merged opponent states per strategy
    seconds: float

    @property
    def values(self) -> np.ndarray:
        """``[S, N*N (home), N*N (target), N*N (item)]`` 0/1: whether the item is collectable."""
        ok = (self.steps <= self.max_steps).astype(np.float64)  # [S, B, I]
        b = np.maximum(self.init_class, 0)
        return np.take_along_axis(ok[:, None, :, :], b[..., None], axis=2) * (self.init_class >= 0)[..., None]


# -- the search ----------------------------------------------------------------------------------


def _search(env, energy: float, max_steps: int, nxt, opos):
    """Breadth-first search over ``(b, collector cell, energy level, local opponent state)``.

    ``nxt``/``opos`` from :func:`local_machines` (local state 0 is the reset
    state). Returns ``(steps [B, C], plans [C, B, T])`` (see :class:`Solution`).
    """
    n, c = env.grid_size, env.grid_size**2
    succ = successors(n)
    levels = 1 if math.isinf(energy) else int(energy)
    nb, width = opos.shape
    shape = (nb, c, levels, width)
    size = int(np.prod(shape))
    check_fits(10 * size, f"the exact search over {size:,} states ({levels:,} energy levels)",
               "the energy (or make it unlimited)")  # parent int64, action int8, seen bool per state
    parent = np.full(size, -1, np.int64)
    action = np.zeros(size, np.int8)
    seen = np.zeros(size, bool)
    frontier = np.ravel_multi_index((np.arange(nb), 0, levels - 1, 0), shape)
    seen[frontier] = True
    steps = np.full(nb * c, NEVER, np.int64)
    src = np.zeros(nb * c, np.int64)
    src_act = np.zeros(nb * c, np.int8)
    for t in range(1, max_steps + 1):
        if frontier.size == 0:
            break
        b, p, e, o = np.unravel_index(frontier, shape)
        o2 = nxt[b, o, p]
        q2 = opos[b, o2]
        p2 = succ[p]  # [F, 9] (2)
        free, met = captures(env, p, q2, p2)  # (1), (3)
        got = free[:, None] & (True if env.reward_when_caught else ~met)
        i, a = np.nonzero(np.broadcast_to(got, p2.shape))
        key = b[i] * c + p2[i, a]
        new = steps[key] == NEVER
        steps[key[new]] = t  # any of several equal candidates is a fastest collection
        src[key[new]], src_act[key[new]] = frontier[i[new]], a[new]
        base = p2 == 0
        if math.isinf(energy):
            e2 = np.broadcast_to(e[:, None], p2.shape)
            alive = free[:, None] & ~met
        else:
            e2 = np.where(base, levels - 1, e[:, None] - 1)
            alive = free[:, None] & ~met & (base | (e[:, None] >= 1))  # (4) level e (energy e+1) -> e, 0 disables
        i, a = np.nonzero(alive)
        cand = np.ravel_multi_index((b[i], p2[i, a], e2[i, a], o2[i]), shape)
        fresh = ~seen[cand]
        cand, i, a = cand[fresh], i[fresh], a[fresh]
        parent[cand], action[cand] = frontier[i], a  # duplicates: any one is a valid first arrival
        frontier = np.unique(cand)
        seen[frontier] = True

    # Plans: walk every collection back to its reset state, all (b, cell) pairs at once.
    hit = np.flatnonzero(steps <= max_steps)
    plans = np.zeros((c, nb, int(steps[hit].max()) if hit.size else 1), np.int8)
    bb, cell = np.divmod(hit, c)
    t = steps[hit]
    plans[cell, bb, t - 1] = src_act[hit]
    state = src[hit]
    for j in range(1, plans.shape[2]):
        live = t - j >= 1
        plans[cell[live], bb[live], t[live] - j - 1] = action[state[live]]
        state = np.where(live, parent[state], state)
    return steps.reshape(nb, c), plans


def solve(env, params) -> Solution:
    """Solve the single-item DCG with full information, for every item cell and strategy (section 5.5.5).

    ``env`` is a :class:`jaxdc.dcg.env.DCG` (its rules: ``reward_when_caught``,
    ``opponent_start``, ``patrol_target``, ``strategies``), ``params`` one
    scalar :class:`~jaxdc.dcg.env.EnvParams` with a whole (or infinite) ``max_energy`` and a
    deterministic ``chase_tie``; ``grid_size <= MAX_GRID_SIZE``. Raises
    ``ValueError`` otherwise, and ``MemoryError`` (before allocating) when the
    search's state table does not fit in memory.
    """
    if env.grid_size > MAX_GRID_SIZE:
        raise ValueError(f"grid_size must be <= {MAX_GRID_SIZE} for the exact bound, got {env.grid_size}")
    energy, max_steps = check_params(params)
    t0 = _time.perf_counter()
    c = env.grid_size**2
    weight = reset_pairs(env)
    results, inits, classes = [], [], []
    for s in range(len(env.strategies)):
        cls_next, cls_pos, init = opponent_machine(env, params, s, weight)
        init_b, init_index = np.unique(init[init >= 0], return_inverse=True)
        table = np.full((c, c), -1, np.int64)
        table[init >= 0] = init_index.reshape(-1)
        results.append(_search(env, energy, max_steps, *local_machines(cls_next, cls_pos, init_b)))
        inits.append(table)
        classes.append(int(cls_next.shape[0]))
    nb = max(st.shape[0] for st, _ in results)
    length = max(pl.shape[2] for _, pl in results)
    steps = np.full((len(results), nb, c), NEVER, np.int64)
    plans = np.zeros((len(results), c, nb, length), np.int8)
    for s, (st, pl) in enumerate(results):
        steps[s, : st.shape[0]] = st
        plans[s, :, : pl.shape[1], : pl.shape[2]] = pl
    return Solution(
        steps=steps.astype(np.int32), init_class=np.stack(inits).astype(np.int32), start_weight=weight,
        plans=plans, strategies=tuple(env.strategies), grid_size=env.grid_size, max_energy=energy,
        max_steps=max_steps, opponent_classes=tuple(classes), seconds=_time.perf_counter() - t0,
    )


def bound_from_solution(sol: Solution, item_cells) -> dict:
    """The full-information bound for items uniform over ``item_cells`` (see :func:`full_information_bound`)."""
    cells = np.asarray(item_cells)
    v = sol.values[..., cells].mean(axis=-1)  # [S, home, target]
    per = (v * sol.start_weight[None]).sum(axis=(1, 2))
    return {
        "total": float(per.mean()),
        "per_strategy": {name: float(x) for name, x in zip(sol.strategies, per)},
    }


def full_information_bound(env, params, reward_area: int | None = None, solution: Solution | None = None) -> dict:
    """The exact full-information bound on the expected one-item episode reward (section 5.5.5, Figs. 5.10-5.12).

    The maximal probability of collecting one unit item placed uniformly in
    the reward area (``reward_area``; default ``env.reward_area``; the whole
    grid when both are ``None``, respecting ``env.items_on_base``) by a
    collector that knows the opponent's strategy and hidden state, averaged
    over the env's reset distribution of the opponent and uniformly over
    ``env.strategies``. No collector can beat it in ``env`` with ``params``.

    Returns ``{"total", "per_strategy": {name: value}, "reward_area", "seconds"}``;
    pass a ``solution`` from :func:`solve` (same env and params) to reuse it
    across reward areas.
    """
    cells = env.reward_area_cells(reward_area)  # validates reward_area
    if solution is not None:
        energy, max_steps = check_params(params)
        have = (solution.grid_size, solution.strategies, solution.max_energy, solution.max_steps)
        want = (env.grid_size, tuple(env.strategies), energy, max_steps)
        if have != want:
            raise ValueError(f"solution was solved for (grid_size, strategies, max_energy, max_steps) = {have}, "
                             f"not {want}")
    t0 = _time.perf_counter()
    sol = solve(env, params) if solution is None else solution
    out = bound_from_solution(sol, cells)
    out["reward_area"] = reward_area if reward_area is not None else env.reward_area
    out["seconds"] = (_time.perf_counter() - t0) if solution is None else sol.seconds
    return out


def optimal_policy(sol: Solution):
    """``policy(key, obs, state) -> action`` replaying the optimal plans, for ``run_episodes``.

    Use with the env and params that ``sol`` was solved for and one unit item
    (``DCG(reward_area=s)``): it looks up ``plans[strategy, item cell,
    class(home, target), time]`` -- full information: the strategy and the
    patrol's ends come from the game state, not the observation.
    """
    plans = jnp.asarray(sol.plans.astype(np.int32))
    init = jnp.asarray(np.maximum(sol.init_class, 0))
    n, length = sol.grid_size, sol.plans.shape[-1]

    def policy(key, obs, state):
        item = jnp.argmax(state.items.reshape(-1))
        b = init[state.strategy, grid.flat_index(state.opponent.home, n), grid.flat_index(state.opponent.target, n)]
        t = jnp.minimum(state.time, length - 1)
        return jnp.where(state.time < length, plans[state.strategy, item, b, t], 0)

    return policy
