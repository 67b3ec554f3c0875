"""The full-information optimum of one DCG game with many items (section 5.3; the standard game of 5.5.1).

:mod:`jaxdc.dcg.exact.one_item` solves the single-item game of section 5.5.5 for all
start states at once. Here the yardstick is carried to the standard game of
5.5.1 (10 unit rewards dropped over the grid), one sampled game at a time:
given the whole initial state -- the item drop, the opponent's strategy and
hidden state (patrol start, far end) -- the game is deterministic (with a
deterministic ``chase_tie``), so the most reward any collector can take from
it is a search over the states ``(collected item cells, collector cell,
energy level, opponent state)``.

A breadth-first search from the reset state finds each such state's earliest
arrival; a state reached earlier is never worse (the rules are
time-homogeneous and the step cap ``max_steps`` only bounds the total), so the
best reward over every transition of the search within ``max_steps`` steps is
the optimum, and its parents give an open-loop action plan that earns it.

The transition is that of :meth:`jaxdc.dcg.env.DCG.step_env`, with the
opponent tabulated from the env's own strategy functions by
:mod:`jaxdc.dcg.exact.machine` (states merged when they behave alike). A collector's
episode reward in a game can never exceed that game's optimum, whatever it
observes, so :func:`sampled_bound` -- the mean optimum over games drawn by
:meth:`~jaxdc.dcg.env.DCG.reset_env` -- bounds the expected episode reward of every network
(Figs. 5.6, 5.16) in ``env``; it is an estimate with a standard error, not an
exact expectation. With one item it agrees with :func:`jaxdc.dcg.exact.one_item.solve`.

The search is exponential in the number of distinct item cells ``d`` (``2^d``
item subsets): the standard game's 10 units fall on about 8.4 cells on
average; a game whose search space exceeds ``MAX_SEARCH_STATES`` raises
``ValueError``.
"""

from __future__ import annotations

import math
import time as _time
from typing import NamedTuple

import jax
import numpy as np

from jaxdc.core.memory import check_fits, tree_bytes
from jaxdc.core.validate import check_positive_int
from jaxdc.dcg.exact import machine

#: The largest search space accepted: ``2^d`` item subsets x cells x energy levels x opponent classes
#: (about 0.4 GB of search arrays at the limit). The standard 5 x 5 game needs at most 2^10 x 25 x 15 x 25.
MAX_SEARCH_STATES = 2**26


class Machines(NamedTuple):
    """The opponent of every strategy as a finite machine (:func:`opponent_machines`)."""

    next: tuple  # per strategy: [K, C] next class given the collector's cell
    pos: tuple  # per strategy: [K] the class's cell
    init: tuple  # per strategy: [C, C] class of the reset state (start, far end), -1 if never drawn
    energy: float
    max_steps: int


class GameOptimum(NamedTuple):
    """The optimum of one game: the best episode reward, and an action plan that earns it."""

    reward: float
    plan: np.ndarray  # [T] int8 actions; playing them from the game's reset state earns ``reward``
    item_cells: int  # d, the number of distinct item cells
    states: int  # states the search visited


def opponent_machines(env, params) -> Machines:
    """Tabulate every strategy of ``env`` (validates ``params`` with :func:`jaxdc.dcg.exact.machine.check_params`)."""
    if env.grid_size > machine.MAX_GRID_SIZE:
        raise ValueError(f"grid_size must be <= {machine.MAX_GRID_SIZE} for the exact optimum, got {env.grid_size}")
    energy, max_steps = machine.check_params(params)
    weight = machine.reset_pairs(env)
    tables = [machine.opponent_machine(env, params, s, weight) for s in range(len(env.strategies))]
    nxt, pos, init = zip(*tables)
    return Machines(next=nxt, pos=pos, init=init, energy=energy, max_steps=max_steps)


def _flat(xy, n: int) -> int:
    xy = np.asarray(xy)
    return int(xy[0]) * n + int(xy[1])


def game_optimum(env, machines: Machines, state) -> GameOptimum:
    """The most episode reward any collector can earn in the game that starts at ``state`` (section 5.3).

    ``state`` is one unbatched :class:`jaxdc.dcg.env.EnvState` at reset (time
    0, collector in the base with full energy, the opponent at its start),
    e.g. from ``env.reset_env``; ``machines`` from :func:`opponent_machines`
    for the same ``env`` and params.
    """
    state = jax.device_get(state)
    n, c = env.grid_size, env.grid_size**2
    if (int(state.time) != 0 or _flat(state.pos, n) != 0
            or _flat(state.opponent.pos, n) != _flat(state.opponent.home, n)):
        raise ValueError("state must be a reset state (time 0, collector in the base, opponent at its start)")
    if not math.isinf(machines.energy) and float(state.energy) != machines.energy:
        raise ValueError(f"state.energy {float(state.energy)} differs from the machines' max_energy {machines.energy}")
    items = np.asarray(state.items, np.float64).reshape(-1)
    cells = np.flatnonzero(items > 0)
    d = cells.size
    s = int(state.strategy)
    b = int(machines.init[s][_flat(state.opponent.home, n), _flat(state.opponent.target, n)])
    if b < 0:
        raise ValueError("the opponent's (start, far end) pair is never drawn by this env's reset")
    nxt, opos = machine.local_machines(machines.next[s], machines.pos[s], np.array([b]))
    nxt, opos = nxt[0], opos[0]  # [L, C], [L]; local state 0 is the reset state

    energy, max_steps = machines.energy, machines.max_steps
    levels = 1 if math.isinf(energy) else int(energy)
    shape = (2**d, c, levels, nxt.shape[0])
    size = math.prod(shape)
    if size > MAX_SEARCH_STATES:
        raise ValueError(f"the game has {d} item cells: its search needs {size:,} states (2^{d} x {c} cells x "
                         f"{levels} energy levels x {nxt.shape[0]} opponent states), more than MAX_SEARCH_STATES = "
                         f"{MAX_SEARCH_STATES:,}; use fewer units (total_reward) or less energy")
    bit_of = np.full(c, -1, np.int64)
    bit_of[cells] = np.arange(d)
    masks = np.arange(2**d)
    value = ((masks[:, None] >> np.arange(d)) & 1) @ items[cells]  # reward of each collected subset
    full = 2**d - 1
    succ = machine.successors(n)
    parent = np.full(size, -1, np.int32)
    action = np.zeros(size, np.int8)
    seen = np.zeros(size, bool)
    frontier = np.array([np.ravel_multi_index((0, 0, levels - 1, 0), shape)])
    seen[frontier] = True
    best, best_src, best_act, visited = 0.0, -1, 0, 1
    for _ in range(max_steps):
        if frontier.size == 0 or best >= value[full]:
            break
        m, p, e, o = np.unravel_index(frontier, shape)
        o2 = nxt[o, p]  # (1) the opponent moves
        q2 = opos[o2]
        p2 = succ[p]  # [F, 9] (2) the collector moves and collects
        free, met = machine.captures(env, p, q2, p2)  # (1) not caught before moving, (3) caught after
        bit = bit_of[p2]
        new = (bit >= 0) & (((m[:, None] >> np.maximum(bit, 0)) & 1) == 0)
        m2 = np.where(new, m[:, None] | (1 << np.maximum(bit, 0)), m[:, None])
        counted = free[:, None] & (True if env.reward_when_caught else ~met)
        gain = np.where(counted, value[m2], 0.0)
        i, a = np.unravel_index(np.argmax(gain), gain.shape)
        if gain[i, a] > best:
            best, best_src, best_act = float(gain[i, a]), int(frontier[i]), int(a)
        base = p2 == 0  # (4) energy
        if math.isinf(energy):
            e2 = np.broadcast_to(e[:, None], p2.shape)
            alive = free[:, None] & ~met
        else:
            e2 = np.where(base, levels - 1, e[:, None] - 1)
            alive = free[:, None] & ~met & (base | (e[:, None] >= 1))
        alive &= m2 != full  # everything collected: the game is over
        i, a = np.nonzero(alive)
        cand = np.ravel_multi_index((m2[i, a], p2[i, a], e2[i, a], o2[i]), shape)
        fresh = ~seen[cand]
        cand, i, a = cand[fresh], i[fresh], a[fresh]
        parent[cand], action[cand] = frontier[i], a  # duplicates: any one is a valid earliest arrival
        frontier = np.unique(cand)
        seen[frontier] = True
        visited += frontier.size

    plan = machine.walk_back(parent, action, best_src, best_act)
    return GameOptimum(reward=best, plan=plan, item_cells=d, states=visited)


def sampled_bound(env, params, key, episodes: int, progress: bool = False) -> dict:
    """The full-information bound on the expected episode reward, estimated over ``episodes`` games.

    Game ``i`` is ``env.reset_env(jax.random.split(key, episodes)[i], params)``.
    Returns ``{"mean", "se", "sd",
    "per_strategy": {name: {"mean", "se", "episodes"}}, "episodes",
    "item_cells_mean", "seconds", "rewards"}`` where ``rewards`` is the
    ``[episodes]`` array of per-game optima. ``MemoryError`` (before any work) when the ``episodes``
    initial states do not fit in memory.
    """
    t0 = _time.perf_counter()
    machines = opponent_machines(env, params)
    states = draw_games(env, params, key, episodes)
    out = [game_optimum(env, machines, game) for game in games(states, episodes, progress)]
    res = summarise(env, states, np.array([g.reward for g in out]))
    res["item_cells_mean"] = float(np.mean([g.item_cells for g in out]))
    res["seconds"] = _time.perf_counter() - t0
    return res


def draw_games(env, params, key, episodes: int):
    """The reset states of ``episodes`` games, game ``i`` from ``jax.random.split(key, episodes)[i]`` (host arrays);
    ``MemoryError`` (before any work) when they do not fit in memory."""
    check_positive_int("episodes", episodes)
    one = jax.eval_shape(env.reset_env, jax.random.PRNGKey(0), params)
    check_fits(2 * episodes * tree_bytes(one), f"the initial states of {episodes} sampled games",
               "the number of games (episodes)")
    _, states = jax.jit(jax.vmap(env.reset_env, in_axes=(0, None)))(jax.random.split(key, episodes), params)
    return jax.device_get(states)


def games(states, episodes: int, progress: bool = False):
    """Game ``i`` of :func:`draw_games`'s batch, one at a time (with a progress bar when ``progress``)."""
    index = range(episodes)
    if progress:
        from tqdm.auto import tqdm

        index = tqdm(index, desc="full-information optimum", unit="game")
    for i in index:
        yield jax.tree_util.tree_map(lambda x, i=i: x[i], states)


def summarise(env, states, rewards: np.ndarray) -> dict:
    """``{"mean", "se", "sd", "episodes", "per_strategy", "rewards"}`` of per-game ``rewards`` (see
    :func:`sampled_bound`)."""

    def stats(x):
        sd = float(x.std(ddof=1)) if x.size > 1 else 0.0
        return {"mean": float(x.mean()), "se": sd / math.sqrt(x.size), "sd": sd, "episodes": int(x.size)}

    strategy = np.asarray(states.strategy)
    res = stats(rewards)
    res["per_strategy"] = {name: stats(rewards[strategy == s]) for s, name in enumerate(env.strategies)
                           if np.any(strategy == s)}
    res["rewards"] = rewards
    return res
