"""The unlimited-energy bound of the DCP (jaxdc.dcp.exact.unlimited; beyond the thesis, docs/generalisation.md)."""

from __future__ import annotations

import functools
import itertools

import jax
import numpy as np
import pytest

from jaxdc.dcp import instances
from jaxdc.dcp.env import DCP
from jaxdc.dcp.evaluate import evaluate_heuristic
from jaxdc.dcp.exact.optimal import solve_single_item
from jaxdc.dcp.exact.unlimited import MAX_ITEM_CELLS, evaluate_bound, reach_table, tour_bound

MOVES = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)]


def brute_force_unlimited(rho, items, start, horizon):
    """The optimal expected reward of ``horizon`` moves with unlimited energy, by plain recursion over the
    MDP of section 4.3 (move, be paid the cell's item, then draw the cell's risk)."""
    n = len(rho)
    reward = {(r, c): float(items[r][c]) for r in range(n) for c in range(n) if items[r][c] > 0}

    @functools.lru_cache(maxsize=None)
    def val(r, c, left, t):
        if t == 0 or not left:
            return 0.0
        best = 0.0
        for dr, dc in MOVES:
            nr, nc = min(max(r + dr, 0), n - 1), min(max(c + dc, 0), n - 1)
            gain = reward[(nr, nc)] if (nr, nc) in left else 0.0
            rest = left - {(nr, nc)}
            best = max(best, gain + (1.0 - rho[nr][nc]) * val(nr, nc, rest, t - 1))
        return best

    return val(start // n, start % n, frozenset(reward), horizon)


def _instance(rng, n, cells, low=0.0, high=0.6):
    risk = rng.uniform(low, high, (n, n))
    risk[0, 0] = 0.0
    items = np.zeros(n * n)
    where = rng.choice(np.arange(1, n * n), size=cells, replace=False)
    items[where] = rng.integers(1, 4, cells)
    return risk, items.reshape(n, n), int(rng.integers(0, n * n))


@pytest.mark.parametrize("seed", range(4))
def test_bound_is_the_unlimited_energy_optimum_of_the_mdp(seed):
    """On a 3x3 grid with up to 4 item cells the bound equals the finite-horizon optimum of the MDP itself
    (a horizon long enough for every tour), found by recursion over states, not over tours."""
    rng = np.random.default_rng(seed)
    risk, items, start = _instance(rng, 3, 1 + seed % 4)
    expected = brute_force_unlimited(risk.tolist(), items.tolist(), start, horizon=16)
    assert tour_bound(reach_table(risk), risk, items, start) == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_bound_maximises_over_item_orders_on_larger_grids():
    """Against every order (and prefix) of up to 6 item cells on a 5x5 grid."""
    rng = np.random.default_rng(11)
    for _ in range(6):
        risk, items, start = _instance(rng, 5, int(rng.integers(2, 7)))
        q, rho, r = reach_table(risk), risk.reshape(-1), items.reshape(-1)
        best = 0.0
        cells = np.flatnonzero(r > 0)
        for k in range(1, len(cells) + 1):
            for order in itertools.permutations(cells, k):
                p, value, prev = 1.0, 0.0, start
                for j, v in enumerate(order):
                    p *= q[prev, v] * (1.0 if j == 0 else 1.0 - rho[prev])
                    value += p * r[v]
                    prev = v
                best = max(best, value)
        assert tour_bound(q, risk, items, start) == pytest.approx(best, rel=1e-12)


def test_one_item_bound_is_the_exact_optimum_with_a_large_budget_and_above_it_with_a_small_one():
    rng = np.random.default_rng(3)
    risk = rng.uniform(0.0, 0.5, (4, 4)).astype(np.float32).astype(np.float64)  # the solver reads float32 maps
    risk[0, 0] = 0.0
    q = reach_table(risk)
    big = solve_single_item(risk, 30, 30, grid_size=4)
    small = solve_single_item(risk, 3, 2, grid_size=4)
    gaps = []
    for cell in range(1, 16):
        items = np.zeros(16)
        items[cell] = 1.0
        for start in range(16):
            b = tour_bound(q, risk, items, start)
            assert b == pytest.approx(big.values[start, 30, cell], abs=1e-9)
            assert small.values[start, 2, cell] <= b + 1e-9
            gaps.append(b - small.values[start, 2, cell])
    assert max(gaps) > 0.05  # the budget binds somewhere: the bound is then strictly above


def test_reach_table_pays_the_item_before_the_cells_risk():
    risk = np.zeros((3, 3))
    risk[1, 1] = 1.0  # a certain loss, but its item is paid first
    items = np.zeros((3, 3))
    items[1, 1] = 2.0
    items[2, 2] = 5.0
    q = reach_table(risk)
    assert np.isfinite(q).all() and q[0, 4] == 1.0 and q[0, 8] == 1.0  # around the centre to the corner
    assert tour_bound(q, risk, items, 0) == pytest.approx(7.0)  # the corner first, then the centre
    assert tour_bound(q, np.zeros((3, 3)), items, 0) == pytest.approx(7.0)


def test_bound_bounds_the_navigators_on_the_same_episodes():
    """Every navigator's mean reward stays below the bound on the same episodes (paired by key), and the bound
    depends on the episodes' items, not on the budget."""
    env = DCP(grid_size=5, total_reward=8)
    risk = np.random.default_rng(5).uniform(0.0, 0.3, (5, 5))
    risk[0, 0] = 0.0
    key = jax.random.PRNGKey(2)
    small = evaluate_bound(env, instances.fixed_instance(env, risk, (4.0, 8.0)), key, 400)
    large = evaluate_bound(env, instances.fixed_instance(env, risk, (40.0, 80.0)), key, 400)
    np.testing.assert_array_equal(small.values, large.values)
    final = evaluate_heuristic(env, instances.fixed_instance(env, risk, (40.0, 80.0)), "safe_both", key, 400)
    diff = np.asarray(final.ep_reward, np.float64) - small.values
    assert diff.mean() <= 3.0 * diff.std() / np.sqrt(len(diff))
    assert np.all(small.values <= 8.0 + 1e-9) and np.all(small.values > 0.0)


def test_bound_refuses_too_many_item_cells_by_name():
    env = DCP(total_reward=MAX_ITEM_CELLS + 1)
    with pytest.raises(ValueError, match=r"total_reward must be <= 20.*got 21"):
        evaluate_bound(env, instances.fixed_instance(env, np.zeros((8, 8)), (8.0, 16.0)), jax.random.PRNGKey(0), 2)
    items = np.ones(64)
    with pytest.raises(ValueError, match="at most 20 item cells, got 64"):
        tour_bound(reach_table(np.zeros((8, 8))), np.zeros((8, 8)), items, 0)
    with pytest.raises(ValueError, match="square"):
        reach_table(np.zeros((2, 3)))
    q = reach_table(np.zeros((8, 8)))
    for start in (64, -1, 2.0, True):
        with pytest.raises(ValueError, match=r"start must be a flat cell index in \[0, 64\)"):
            tour_bound(q, np.zeros((8, 8)), np.eye(8), start)
    for bad in (np.nan, -1.0, np.inf):
        items = np.eye(8)
        items[3, 3] = bad
        with pytest.raises(ValueError, match="items must be finite rewards >= 0"):
            tour_bound(q, np.zeros((8, 8)), items, 0)
    for risk, match in ((np.full((8, 8), np.nan), "finite"), (np.full((8, 8), 1.5), r"\[0, 1\]")):
        risk[0, 0] = 0.0
        with pytest.raises(ValueError, match=match):
            reach_table(risk)
    with pytest.raises(ValueError, match=r"q of shape \(16, 16\)"):
        tour_bound(reach_table(np.zeros((8, 8))), np.zeros((4, 4)), np.eye(4), 0)
