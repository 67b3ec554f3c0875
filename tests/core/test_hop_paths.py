"""Safest routes within a move budget (:mod:`jaxdc.core.hop_paths`), against an enumeration of every path."""

from __future__ import annotations

import itertools

import jax
import numpy as np
import pytest

from jaxdc.core import grid
from jaxdc.core.hop_paths import safest_within
from jaxdc.core.paths import PATH_RISK, safest_paths, successors

_within = jax.jit(safest_within)


def _enumerated(risk, path_risk, src, dst, moves):
    """``(best success, fewest moves among the best, first actions of those)`` over every path of at most
    ``moves`` moves, or ``None`` where none reaches ``dst`` with a success above 0."""
    n = risk.shape[0]
    succ, valid = successors(n)
    r = risk.reshape(-1)
    paths, found = [((int(src),), 1.0)], []
    for _ in range(moves):
        paths = [(path + (int(succ[path[-1], a]),),
                  p * (1.0 - (r[path[-1]] if path_risk == "departed" else r[succ[path[-1], a]])))
                 for path, p in paths for a in range(8) if valid[path[-1], a]]
        found += [x for x in paths if x[0][-1] == dst]
    if not found or max(p for _, p in found) <= 0:
        return None
    best = max(p for _, p in found)
    tied = [path for path, p in found if p >= best * (1 - 1e-4)]
    fewest = min(len(path) - 1 for path in tied)
    firsts = {a + 1 for path in tied if len(path) - 1 == fewest for a in range(8)
              if valid[src, a] and succ[src, a] == path[1]}
    return best, fewest, firsts


@pytest.mark.parametrize("path_risk", PATH_RISK)
def test_the_route_is_the_safest_of_at_most_h_moves(path_risk):
    """On random 3x3 and 4x4 maps (some with a risk-1 cell), for random pairs and budgets: the route is feasible
    exactly when some path of at most ``h`` moves succeeds, has their best success probability and the fewest moves
    among the safest of them, and starts with one of their first moves."""
    rng = np.random.default_rng(3)
    for trial in range(8):
        n = 3 + trial % 2
        risk = rng.uniform(0.0, 0.6, (n, n)).astype(np.float32)
        risk[0, 0] = 0.0
        if trial % 3 == 0:
            risk[rng.integers(0, n), rng.integers(0, n)] = 1.0
        table = safest_paths(risk, path_risk)
        for _ in range(6):
            src, dst = (int(x) for x in rng.integers(0, n * n, 2))
            moves = int(rng.integers(0, 6))
            route = _within(table, src, dst, moves)
            want = _enumerated(risk, path_risk, src, dst, moves)
            if src == dst:
                assert bool(route.feasible) and int(route.action) == grid.STAY and int(route.steps) == 0
            elif want is None:
                assert not bool(route.feasible) and int(route.action) == grid.STAY
            else:
                assert bool(route.feasible), (src, dst, moves)
                assert int(route.steps) == want[1] and int(route.action) in want[2], (src, dst, moves, want, route)
                np.testing.assert_allclose(float(route.success), want[0], rtol=1e-4)


def test_a_large_budget_gives_the_safest_path_of_the_table():
    """With every move allowed, the route's length and first move's success are the table's safest path."""
    rng = np.random.default_rng(5)
    risk = rng.uniform(0.0, 0.5, (5, 5)).astype(np.float32)
    table = safest_paths(risk)
    for src, dst in itertools.product(range(0, 25, 4), range(0, 25, 3)):
        route = _within(table, src, dst, 25)
        assert int(route.steps) == int(table.steps[src, dst])
        if src != dst:
            nxt = int(successors(5)[0][src, int(route.action) - 1])
            got = float(table.success[src, nxt]) * float(table.success[nxt, dst])
            np.testing.assert_allclose(got, float(table.success[src, dst]), rtol=1e-4)


def test_a_tight_budget_takes_the_shortcut_and_too_small_a_budget_none():
    """A wall of risk 0.5 across the middle column of a 5x5 grid, open at the bottom: the safest path from the top
    left to the top right goes round (8 moves); with 4 moves the route crosses the wall; with 3 none exists."""
    risk = np.zeros((5, 5), np.float32)
    risk[:4, 2] = 0.5
    table = safest_paths(risk)
    src, dst = 0, 4  # (0, 0) -> (0, 4)
    assert int(table.steps[src, dst]) == 8
    assert int(_within(table, src, dst, 8).steps) == 8
    short = _within(table, src, dst, 4)
    assert bool(short.feasible) and int(short.steps) == 4
    none = _within(table, src, dst, 3)
    assert not bool(none.feasible) and int(none.action) == grid.STAY
    assert not bool(_within(table, src, dst, -2).feasible)  # a negative budget counts as 0
