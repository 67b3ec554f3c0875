"""The full-information optimum of one team DCG game with two collectors (issue 29; section 5.3 for a team).

The thesis' conclusion names a team of collectors as the game's next step. The team game's rules
(``docs/dcg.md``, "The team game") play section 5.3's transition for everyone at once: the opponent
moves first, chasing its *target* -- the nearest active collector (Manhattan distance for
``restricted``, Chebyshev otherwise; ties to the lowest index), with ``with_fog``/``double_blind``
reading the fog in one of :data:`FOG_TARGETS` (``"visible"``: the nearest active collector outside
the fog, staying when all are in it; ``"nearest"``: the nearest active collector, staying if it is in
the fog); an active collector it lands on is caught (rule 1); the others move and collect (a shared
item cell counts once for the team); a collector ending on the opponent is caught (rule 3); energy
refills in the base, else drops by one, 0 disables (rule 4). A disabled collector is ignored by the
opponent and collects nothing. The game ends when both collectors are disabled or every item is
collected, and is truncated at ``max_steps``.

Given the whole initial state (the drop, the opponent's strategy and hidden state) and a
deterministic ``chase_tie``, the game is deterministic, so the best team reward is a search over the
joint states ``(collected item cells, cell 1, cell 2, energy 1, energy 2, active flags, opponent
class)``, exactly as :mod:`jaxdc.dcg.exact.many_items` searches one collector: a breadth-first search
from the reset state keeps each state's earliest arrival (a state reached earlier is never worse: the
rules are time-homogeneous and the step cap only bounds the total), the best team reward over every
transition within ``max_steps`` steps is the optimum, and the parents give an open-loop joint plan
(``[T, 2]`` actions) that earns it (:func:`replay` plays a plan by the search's own transition, step by
step, for a cross-check against the team env). The opponent is the one-collector machine of
:mod:`jaxdc.dcg.exact.machine`, tabulated from the env's own strategy functions and fed the target's
cell: merged opponent states share their cell, so they pick the same target and stay alike.

Memory: the search keeps 6 bytes per joint state (seen, parent, joint action) for ``2^d`` item subsets
(``d`` distinct item cells) x ``W = C^2 lv^2 + 2 C lv`` collector states (``C`` cells, ``lv`` energy
levels; the second term the states with one collector left) x ``L`` opponent classes; a game over
``MAX_SEARCH_STATES`` (``2^26``, about 0.4 GB) raises ``ValueError`` naming the sizes. The standard
game (5 x 5, 10 units on about 8.4 cells, energy 15) needs about ``2^8.4 x 1.4e5 x 25 ~ 1e9`` states and
is refused: :func:`reach_bound` is its documented upper bound, and the exact value fits smaller games
(docs/dcg.md).
"""

from __future__ import annotations

import math
import time as _time
from typing import NamedTuple

import jax
import numpy as np

from jaxdc.core import grid
from jaxdc.core.memory import check_fits
from jaxdc.core.validate import check_choice, check_positive_int
from jaxdc.dcg.exact import machine
from jaxdc.dcg.exact.many_items import (
    MAX_SEARCH_STATES,
    Machines,
    draw_games,
    games,
    opponent_machines,
    summarise,
)
from jaxdc.dcg.opponents import FOG_STRATEGIES

#: How a fog strategy (``with_fog``, ``double_blind``) picks its target among the active collectors.
FOG_TARGETS = ("visible", "nearest")
#: The team size this search solves.
COLLECTORS = 2
#: Joint actions expanded at once (memory of one chunk: about 80 bytes per candidate).
_CHUNK = 1 << 20


class TeamOptimum(NamedTuple):
    """The optimum of one team game: the best team reward, and a joint plan that earns it."""

    reward: float
    plan: np.ndarray  # [T, 2] int8 actions per collector (a disabled collector's are 0 and ignored)
    item_cells: int  # d, the number of distinct item cells
    states: int  # joint states the search visited


class _Game(NamedTuple):
    """One game's tables: the opponent's local machine, the item bits, the strategy's target rule."""

    n: int
    nxt: np.ndarray  # [L, C] next opponent class given its target's cell
    opos: np.ndarray  # [L] the class's cell
    bit_of: np.ndarray  # [C] item bit of each cell, -1 without an item
    value: np.ndarray  # [2^d] team reward of each collected subset
    levels: int  # energy levels (1 with unlimited energy)
    unlimited: bool  # unlimited energy
    manhattan: bool  # the strategy chases with the restricted actions
    fog: str | None  # the fog reading for a fog strategy, else None


def target_cells(n: int, q, cells, active, manhattan: bool, fog: str | None):
    """The cell the opponent at ``q`` [F] chases: its nearest active collector among ``cells`` [F, K].

    Distance in moves of the strategy's actions (Manhattan with ``manhattan``, else Chebyshev), ties to
    the lowest index; ``active`` [F, K] bool (at least one per row). ``fog="visible"``: the nearest active
    collector outside the fog (row 0 or column 0), or -- when every active one is in it -- the first active
    collector's (fog) cell, where a fog strategy stays; ``"nearest"`` or ``None``: the nearest active one.
    """
    qr, qc = np.divmod(np.asarray(q)[:, None], n)
    r, c = np.divmod(np.asarray(cells), n)
    dr, dc = np.abs(r - qr), np.abs(c - qc)
    dist = dr + dc if manhattan else np.maximum(dr, dc)
    big = 4 * n
    dist = np.where(active, dist, big)
    if fog == "visible":
        clear = active & (r != 0) & (c != 0)
        dist = np.where(clear, dist, np.where(active, 2 * big, 3 * big))  # every active one in the fog: any fog cell
    pick = np.argmin(dist, axis=1)  # the first minimum: ties to the lowest index
    return np.take_along_axis(np.asarray(cells), pick[:, None], axis=1)[:, 0]


def target_rule(env, strategy: int, fog_target: str) -> tuple[bool, str | None]:
    """``(manhattan, fog)`` of strategy index ``strategy`` of ``env`` (see :func:`target_cells`)."""
    name = env.strategies[strategy]
    return name == "restricted", (fog_target if name in FOG_STRATEGIES else None)


def _game(env, machines: Machines, state, fog_target: str) -> _Game:
    state = jax.device_get(state)
    n, c = env.grid_size, env.grid_size**2
    flat = lambda xy: int(np.asarray(xy)[0]) * n + int(np.asarray(xy)[1])  # noqa: E731
    if int(state.time) != 0 or flat(state.pos) != 0 or flat(state.opponent.pos) != flat(state.opponent.home):
        raise ValueError("state must be a reset state (time 0, collector in the base, opponent at its start)")
    if not math.isinf(machines.energy) and float(state.energy) != machines.energy:
        raise ValueError(f"state.energy {float(state.energy)} differs from the machines' max_energy {machines.energy}")
    s = int(state.strategy)
    b = int(machines.init[s][flat(state.opponent.home), flat(state.opponent.target)])
    if b < 0:
        raise ValueError("the opponent's (start, far end) pair is never drawn by this env's reset")
    nxt, opos = machine.local_machines(machines.next[s], machines.pos[s], np.array([b]))
    items = np.asarray(state.items, np.float64).reshape(-1)
    cells = np.flatnonzero(items > 0)
    bit_of = np.full(c, -1, np.int64)
    bit_of[cells] = np.arange(cells.size)
    value = ((np.arange(2**cells.size)[:, None] >> np.arange(cells.size)) & 1) @ items[cells]
    levels = 1 if math.isinf(machines.energy) else int(machines.energy)
    return _Game(n, nxt[0], opos[0], bit_of, value, levels, math.isinf(machines.energy),
                 *target_rule(env, s, fog_target))


def step(env, g: _Game, m, p, e, act, o, a):
    """The team transition on arrays (section 5.3's rules for everyone at once, docs/dcg.md).

    ``m`` [G] collected subsets, ``p``/``e``/``act`` [G, 2] cells, energy levels (energy - 1), active
    flags, ``o`` [G] opponent classes, ``a`` [G, 2] actions. Returns ``(m2, p2, e2, act2, o2, gain, q2)``:
    the next state (a disabled collector's cell and level set to 0), the team reward collected so far
    (the value of ``m2``) and the opponent's new cell.
    """
    q = g.opos[o]
    o2 = g.nxt[o, target_cells(g.n, q, p, act, g.manhattan, g.fog)]  # (1) the opponent moves
    q2 = g.opos[o2]
    moved = machine.successors(g.n)[p, a]  # [G, 2]
    m2, p2, act2 = m.copy(), p.copy(), np.zeros_like(act)
    e2 = np.zeros_like(e)
    for i in range(COLLECTORS):
        free, met = machine.captures(env, p[:, i], q2, moved[:, i, None])
        go = act[:, i] & free  # (1) not caught before moving: (2) it moves and collects
        met = go & met[:, 0]  # (3) caught after moving
        p2[:, i] = np.where(go, moved[:, i], p[:, i])
        bit = g.bit_of[p2[:, i]]
        counted = go & (bit >= 0) & (env.reward_when_caught | ~met)
        m2 = np.where(counted, m2 | (1 << np.maximum(bit, 0)), m2)
        base = p2[:, i] == 0  # (4) energy
        if g.unlimited:
            alive = go & ~met
        else:
            e2[:, i] = np.where(base, g.levels - 1, e[:, i] - 1)
            alive = go & ~met & (base | (e[:, i] >= 1))
        act2[:, i] = alive
    p2 = np.where(act2, p2, 0)
    e2 = np.where(act2, e2, 0)
    return m2, p2, e2, act2, o2, g.value[m2], q2


class _Codec(NamedTuple):
    """Flat indices of joint states: ``(m * L + o) * W + w``, ``w`` the collectors' part -- both active
    ``((p1 C + p2) lv + e1) lv + e2``, then only collector 1 (``p1 lv + e1``), then only collector 2."""

    c: int
    levels: int
    classes: int

    @property
    def both(self) -> int:
        return self.c * self.c * self.levels * self.levels

    @property
    def width(self) -> int:
        return self.both + 2 * self.c * self.levels

    def size(self, d: int) -> int:
        return 2**d * self.classes * self.width

    def encode(self, m, p, e, act, o):
        c, lv = self.c, self.levels
        both = ((p[:, 0] * c + p[:, 1]) * lv + e[:, 0]) * lv + e[:, 1]
        solo = self.both + p * lv + e  # [G, 2]
        w = np.where(act[:, 0] & act[:, 1], both, np.where(act[:, 0], solo[:, 0], solo[:, 1] + c * lv))
        return (m.astype(np.int64) * self.classes + o) * self.width + w

    def decode(self, x):
        c, lv = self.c, self.levels
        mo, w = np.divmod(x, self.width)
        m, o = np.divmod(mo, self.classes)
        pair = np.stack(np.unravel_index(np.minimum(w, self.both - 1), (c, c, lv, lv)), -1)
        second, rest = np.divmod(np.maximum(w - self.both, 0), c * lv)
        cell, level = np.divmod(rest, lv)
        solo = (w >= self.both)[:, None]
        mine = np.arange(COLLECTORS)[None, :] == second[:, None]
        p = np.where(solo, np.where(mine, cell[:, None], 0), pair[:, :2])
        e = np.where(solo, np.where(mine, level[:, None], 0), pair[:, 2:])
        act = np.where(solo, mine, True)
        return m, p, e, act, o


_A = grid.NUM_ACTIONS
_JOINT = np.stack(np.divmod(np.arange(_A**2), _A), -1)  # [81, 2] joint actions, stored as a1 * 9 + a2


def _start(g: _Game):
    """The reset state as arrays of one: both collectors in the base with full energy, the opponent's class 0."""
    return (np.zeros(1, np.int64), np.zeros((1, 2), np.int64), np.full((1, 2), g.levels - 1, np.int64),
            np.ones((1, 2), bool), np.zeros(1, np.int64))


def search_size(env, machines: Machines, state, fog_target: str = "visible") -> int:
    """The number of joint states :func:`game_optimum` would allocate for this game (``2^d x L x W``)."""
    g = _game(env, machines, state, fog_target)
    return _Codec(env.grid_size**2, g.levels, g.nxt.shape[0]).size(int((g.bit_of >= 0).sum()))


def game_optimum(env, machines: Machines, state, fog_target: str = "visible") -> TeamOptimum:
    """The most team reward two collectors can earn in the game that starts at ``state`` (docs/dcg.md).

    ``state`` is a one-collector reset state of ``env`` (a :class:`jaxdc.dcg.env.DCG`, whose rule
    readings apply per collector): the items and the opponent as the team game's reset draws them; both
    collectors start in the base with its energy. ``machines`` from
    :func:`jaxdc.dcg.exact.many_items.opponent_machines` (same env and params). ``ValueError`` when the
    search needs more than ``MAX_SEARCH_STATES`` states (the message names the sizes), ``MemoryError``
    (before allocating) when its tables do not fit in memory.
    """
    fog_target = check_choice("fog_target", fog_target, FOG_TARGETS)
    g = _game(env, machines, state, fog_target)
    d, classes = int((g.bit_of >= 0).sum()), g.nxt.shape[0]
    codec = _Codec(env.grid_size**2, g.levels, classes)
    size = codec.size(d)
    if size > MAX_SEARCH_STATES:
        raise ValueError(f"the two-collector game has {d} item cells: its search needs {size:,} states (2^{d} x "
                         f"{codec.width:,} collector states ({codec.c} cells, {g.levels} energy levels each) x "
                         f"{classes} opponent states), more than MAX_SEARCH_STATES = {MAX_SEARCH_STATES:,}; use a "
                         "smaller grid, fewer units (total_reward) or less energy, or the upper bound reach_bound")
    check_fits(6 * size, f"the two-collector search over {size:,} states", "the grid, units or energy")
    parent = np.full(size, -1, np.int32)
    action = np.zeros(size, np.int8)
    seen = np.zeros(size, bool)
    frontier = codec.encode(*_start(g))
    seen[frontier] = True
    full = 2**d - 1
    best, best_src, best_act, visited = 0.0, -1, 0, 1
    per_chunk = max(1, _CHUNK // len(_JOINT))
    for _ in range(machines.max_steps):
        if frontier.size == 0 or best >= g.value[full]:
            break
        layer = []
        for lo in range(0, frontier.size, per_chunk):
            src_state = frontier[lo: lo + per_chunk]
            m, p, e, act, o = codec.decode(src_state)
            src = np.repeat(np.arange(src_state.size), len(_JOINT))
            a = np.tile(_JOINT, (src_state.size, 1))
            keep = (act[src] | (a == 0)).all(axis=1)  # a disabled collector's action is ignored: take 'stay' only
            src, a = src[keep], a[keep]
            m2, p2, e2, act2, o2, gain, _ = step(env, g, m[src], p[src], e[src], act[src], o[src], a)
            j = int(np.argmax(gain))
            if gain[j] > best:
                best, best_src, best_act = float(gain[j]), int(src_state[src[j]]), int(a[j, 0] * _A + a[j, 1])
            live = np.flatnonzero(act2.any(axis=1) & (m2 != full))  # else the game is over
            cand = codec.encode(m2[live], p2[live], e2[live], act2[live], o2[live])
            cand, first = np.unique(cand, return_index=True)
            fresh = ~seen[cand]
            cand, first = cand[fresh], live[first[fresh]]
            parent[cand], action[cand] = src_state[src[first]], a[first, 0] * _A + a[first, 1]
            seen[cand] = True
            layer.append(cand)
        frontier = np.concatenate(layer)
        visited += frontier.size
    plan = machine.walk_back(parent, action, best_src, best_act)
    return TeamOptimum(reward=best, plan=np.stack(np.divmod(plan.astype(np.int64), _A), -1).astype(np.int8),
                       item_cells=d, states=visited)


def replay(env, machines: Machines, state, plan, fog_target: str = "visible") -> dict:
    """Play a joint plan ``[T, 2]`` from ``state`` by the search's transition (:func:`step`), step by step.

    Returns ``{"reward": [T] team reward per step, "total", "pos": [T+1, 2, 2] (row, col) per collector,
    "active": [T+1, 2], "energy": [T+1, 2] (NaN once disabled), "opponent": [T+1, 2], "steps"}`` --
    the trajectory to hold against the team env's (nothing is collected after the game ends).
    """
    fog_target = check_choice("fog_target", fog_target, FOG_TARGETS)
    plan = np.asarray(plan, np.int64).reshape(-1, COLLECTORS)
    g = _game(env, machines, state, fog_target)
    n, full = env.grid_size, g.value.size - 1
    m, p, e, act, o = _start(g)
    pos, active, levels, opp, rewards = [p[0].copy()], [act[0].copy()], [e[0].copy()], [g.opos[o][0]], []
    done = False
    for a in plan:
        if done:
            break
        m2, p, e2, act2, o, gain, q2 = step(env, g, m, p, e, act, o, a[None, :])
        rewards.append(float(g.value[m2][0] - g.value[m][0]))
        m, e, act = m2, e2, act2
        pos.append(p[0].copy())
        active.append(act[0].copy())
        levels.append(e[0].copy())
        opp.append(q2[0])
        done = not act[0].any() or m[0] == full
    cells, active = np.stack(pos), np.stack(active)
    energy = np.full(active.shape, np.inf) if g.unlimited else np.stack(levels) + 1.0
    return {"reward": np.array(rewards), "total": float(np.sum(rewards)),
            "pos": np.stack(np.divmod(cells, n), -1), "active": active, "energy": np.where(active, energy, np.nan),
            "opponent": np.stack(np.divmod(np.array(opp), n), -1), "steps": len(rewards)}


def reach_bound(env, params, state) -> float:
    """A proven upper bound on any team's reward in a game: the units on cells within reach of the base.

    A collector moves one Chebyshev step per action and collects a cell's item only by entering it (or
    staying on it), so an item at Chebyshev distance ``r`` from the base can be collected only when
    ``r <= max_steps`` (each step moves at most one cell) and ``r <= max_energy`` (after ``j`` steps out of
    the base a collector has ``max_energy - j`` energy, and is disabled at 0 -- the item of that step
    still counting). This holds for any number of collectors and every opponent: it is the game without
    the opponent, relaxed further to "every reachable item is collected". In the standard game (5 x 5,
    energy 15, 100 steps) it is exactly the dropped total: without the opponent one collector alone
    collects everything (one round trip of at most 8 steps from the base per item cell, at most 10
    cells, 80 steps), so no bound that ignores the opponent can be lower.
    """
    energy, max_steps = machine.check_params(params)
    n = env.grid_size
    r, c = np.divmod(np.arange(n * n), n)
    near = np.maximum(r, c) <= min(energy, max_steps)
    return float(np.asarray(jax.device_get(state.items), np.float64).reshape(-1)[near].sum())


#: How :func:`sampled_bound` values each game: the exact optimum (refusing a game that does not fit), the
#: proven upper bound :func:`reach_bound`, or (``auto``) the exact optimum when every sampled game fits, else
#: the upper bound for all.
METHODS = ("auto", "exact", "upper")


def sampled_bound(env, params, key, episodes: int, fog_target: str = "visible", method: str = "auto",
                  progress: bool = False) -> dict:
    """The two-collector full-information bound on the expected team reward, over ``episodes`` sampled games.

    Game ``i`` is ``env.reset_env(jax.random.split(key, episodes)[i], params)`` -- the items and the
    opponent as the team game's reset draws them -- played by two collectors (the same games as
    :func:`jaxdc.dcg.exact.many_items.sampled_bound` with the same key). Returns
    ``{"mean", "se", "sd", "episodes", "per_strategy", "kind" ("exact" or "upper_bound"), "collectors",
    "fog_target", "largest_search", "item_cells_mean", "seconds", "rewards"}``; ``largest_search`` is the
    most joint states a sampled game needs (against ``MAX_SEARCH_STATES``).
    """
    check_positive_int("episodes", episodes)
    fog_target = check_choice("fog_target", fog_target, FOG_TARGETS)
    method = check_choice("method", method, METHODS)
    t0 = _time.perf_counter()
    machines = opponent_machines(env, params)
    states = draw_games(env, params, key, episodes)
    sizes = [search_size(env, machines, game, fog_target) for game in games(states, episodes)]
    exact = method == "exact" or (method == "auto" and max(sizes) <= MAX_SEARCH_STATES)
    if exact:
        rewards = [game_optimum(env, machines, game, fog_target).reward
                   for game in games(states, episodes, progress)]
    else:
        rewards = [reach_bound(env, params, game) for game in games(states, episodes)]
    res = summarise(env, states, np.array(rewards, np.float64))
    items = np.asarray(states.items).reshape(episodes, -1)
    res.update(kind="exact" if exact else "upper_bound", collectors=COLLECTORS, fog_target=fog_target,
               largest_search=int(max(sizes)), item_cells_mean=float((items > 0).sum(axis=1).mean()),
               seconds=_time.perf_counter() - t0)
    return res
