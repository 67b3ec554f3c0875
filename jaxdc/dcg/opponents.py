"""Opponent strategies of the Data-collection Game (thesis sections 5.5.1 and 5.5.7).

A strategy is a pure function of arrays

    strategy(key, opp, game, params) -> (action, new_opp)

* ``key`` -- a PRNG key for this step (used only by random tie-breaking here);
* ``opp`` -- the opponent's :class:`OpponentState` *before* it moves;
* ``game`` -- the whole game state (:class:`jaxdc.dcg.env.EnvState`; the
  collector is at ``game.pos``, the items in ``game.items``);
* ``params`` -- the :class:`jaxdc.dcg.env.EnvParams` (``params.chase_tie``
  picks the tie rule of :func:`chase_action`);
* ``action`` -- an index into :data:`jaxdc.core.grid.ACTIONS` (the opponent's
  ``o_t``); the environment applies it (clipped moves, ``grid.move``), so a
  strategy never writes ``pos`` itself;
* ``new_opp`` -- the opponent state with the strategy's memory updated
  (``phase``; ``home``/``target`` are drawn at reset and free to reuse).

:func:`register_strategy` adds a strategy under a name; ``DCG(strategies=...)``
then draws one of the named strategies uniformly per episode (section 5.3:
"it uniformly randomly chooses one for each episode"). The environment never
needs to change for a new strategy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxdc.core import grid

#: How "moves towards the collector" breaks ties between equally good moves.
#: ``straight``: the move that stays closest to the straight line (smallest
#: squared Euclidean distance), then the thesis' action order -- with all 9
#: actions this is ``grid.shortest_move(rule="diagonal")``; with the 5
#: restricted actions it closes the larger axis gap first, rows first on a
#: tie. ``order``: the first action in the thesis' order among the best moves
#: (``grid.shortest_move(rule="order")`` with 9 actions). ``random``: uniform
#: among the best moves.
CHASE_TIES = ("straight", "order", "random")
STRAIGHT, ORDER, RANDOM = range(len(CHASE_TIES))

#: The restricted action set A^- of section 5.5.1: stay, up, down, left, right.
RESTRICTED_ACTIONS = np.arange(grid.NUM_ACTIONS) < 5


@struct.dataclass
class OpponentState:
    pos: jax.Array  # [2] int32 (row, col)
    home: jax.Array  # [2] int32: the start cell (one end of the patrol)
    target: jax.Array  # [2] int32: a random non-base cell drawn at reset (the other end)
    phase: jax.Array  # int32 memory of the strategy (patrol: 0 heading to target, 1 heading home)


StrategyFn = Callable[..., tuple]


@dataclass(frozen=True)
class Strategy:
    """A registered strategy: its function and whether it hides in the fog (section 5.5.7)."""

    name: str
    fn: StrategyFn
    hides_in_fog: bool = False


_REGISTRY: dict[str, Strategy] = {}


def register_strategy(name: str, fn: StrategyFn, *, hides_in_fog: bool = False, overwrite: bool = False) -> Strategy:
    """Register ``fn`` (see the module docs for its signature) under ``name``.

    ``hides_in_fog=True`` makes the collector's observation omit the opponent
    while the collector is in a fog cell (row 0 or column 0), as the
    double-blind variant of section 5.5.7 does. Registering an existing name
    raises ``ValueError`` unless ``overwrite=True``.
    """
    if not isinstance(name, str) or not name:
        raise ValueError(f"strategy name must be a non-empty str, got {name!r}")
    if not callable(fn):
        raise TypeError(f"strategy {name!r}: fn must be callable, got {fn!r}")
    if name in _REGISTRY and not overwrite:
        raise ValueError(f"strategy {name!r} is already registered (pass overwrite=True to replace it)")
    _REGISTRY[name] = Strategy(name, fn, bool(hides_in_fog))
    return _REGISTRY[name]


def registered_strategies() -> tuple[str, ...]:
    """The names of all registered strategies."""
    return tuple(_REGISTRY)


def get_strategies(names) -> tuple[Strategy, ...]:
    """Validate a strategy set (a non-empty sequence of registered names, no repeats)."""
    if isinstance(names, str):
        names = tuple(s.strip() for s in names.split(",") if s.strip())
    try:
        names = tuple(names)
    except TypeError:
        raise TypeError(f"strategies must be a sequence of names, got {names!r}") from None
    if not names:
        raise ValueError(f"strategies must not be empty; registered strategies: {list(_REGISTRY)}")
    unknown = [s for s in names if s not in _REGISTRY]
    if unknown:
        raise ValueError(f"strategies: unknown strategy {unknown[0]!r}; registered strategies: {list(_REGISTRY)}")
    if len(set(names)) != len(names):
        raise ValueError(f"strategies must not repeat a name, got {names}")
    return tuple(_REGISTRY[s] for s in names)


# -- helpers -------------------------------------------------------------------------------


def in_fog(pos):
    """Whether the collector at ``pos`` is in a fog cell: the top or left edge (row 0 or column 0)."""
    return (pos[..., 0] == 0) | (pos[..., 1] == 0)


def chase_action(key, pos, target, grid_size: int, tie, diagonal: bool = True):
    """The action that moves ``pos`` towards ``target`` ("moves towards the collector", 5.5.1).

    The best moves minimise the number of moves still needed with the allowed
    actions: the Chebyshev distance with all 9 actions (``diagonal=True``), the
    Manhattan distance with the 5 restricted ones. ``tie`` (an index into
    :data:`CHASE_TIES`, may be traced) picks one of them. Returns ``stay`` (0)
    when ``pos == target``.
    """
    succ = grid.neighbours(pos, grid_size)  # [9, 2]
    big = jnp.int32(1 << 20)
    if diagonal:
        d = grid.chebyshev(succ, target)
    else:
        d = jnp.where(jnp.asarray(RESTRICTED_ACTIONS), grid.manhattan(succ, target), big)
    best = d == jnp.min(d)
    e2 = jnp.where(best, jnp.sum((succ - target) ** 2, axis=-1), big)
    straight = best & (e2 == jnp.min(e2))
    cand = jnp.where(tie == STRAIGHT, straight, best)
    order_score = -jnp.arange(grid.NUM_ACTIONS, dtype=jnp.float32)
    score = jnp.where(tie == RANDOM, jax.random.uniform(key, (grid.NUM_ACTIONS,)), order_score)
    return jnp.argmax(jnp.where(cand, score, -jnp.inf)).astype(jnp.int32)


# -- the thesis' strategies (section 5.5.1) ----------------------------------------------------


def patrol(key, opp: OpponentState, game, params):
    """**patrol**: back and forth between its start (``home``) and a random non-base cell (``target``).

    It heads for ``target`` first; on reaching an end it turns around and
    heads for the other one, moving along a shortest path (:func:`chase_action`
    with all 9 actions and ``params.chase_tie``).
    """
    n = game.items.shape[0]
    goal = jnp.where(opp.phase == 0, opp.target, opp.home)
    arrived = jnp.all(opp.pos == goal)
    phase = jnp.where(arrived, 1 - opp.phase, opp.phase).astype(jnp.int32)
    goal = jnp.where(phase == 0, opp.target, opp.home)
    return chase_action(key, opp.pos, goal, n, params.chase_tie), opp.replace(phase=phase)


def restricted(key, opp: OpponentState, game, params):
    """**restricted**: always moves towards the collector with stay/up/down/left/right only."""
    n = game.items.shape[0]
    return chase_action(key, opp.pos, game.pos, n, params.chase_tie, diagonal=False), opp


def with_fog(key, opp: OpponentState, game, params):
    """**with-fog**: stays while the collector is on the top or left edge, else chases with all 9 actions."""
    n = game.items.shape[0]
    chase = chase_action(key, opp.pos, game.pos, n, params.chase_tie)
    return jnp.where(in_fog(game.pos), jnp.int32(grid.STAY), chase).astype(jnp.int32), opp


register_strategy("patrol", patrol)
register_strategy("restricted", restricted)
register_strategy("with_fog", with_fog)
# Section 5.5.7: with-fog's moves, and the collector cannot see the opponent from the fog either.
register_strategy("double_blind", with_fog, hides_in_fog=True)

#: The standard strategy set of section 5.5.1; section 5.5.7 swaps with_fog for double_blind.
STANDARD_STRATEGIES = ("patrol", "restricted", "with_fog")
DOUBLE_BLIND_STRATEGIES = ("patrol", "restricted", "double_blind")
#: The strategies whose play depends on the fog cells (section 5.5.7): a drawn frame hatches those cells.
FOG_STRATEGIES = ("with_fog", "double_blind")
