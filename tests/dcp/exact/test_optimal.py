"""Exact single-item DCP optimum (jaxdc.dcp.exact.optimal; Table 4.8, section 4.5.4)."""

from __future__ import annotations

import functools
import math

import jax
import numpy as np
import pytest

from jaxdc.core.rollout import run_episodes
from jaxdc.dcp import navigators
from jaxdc.dcp.env import DCP
from jaxdc.dcp.evaluate import OptimalEvaluation, evaluate_heuristic, evaluate_optimal, summarize
from jaxdc.dcp.exact.optimal import expected_optimum, optimal_policy, solve_single_item

MOVES = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)]


def brute_force_values(rho, big_e, horizon, gamma=1.0):
    """Finite-horizon optimal values by plain recursion, written from the text of section 4.3.

    Returns ``[N*N, E+1, N*N]`` like ``OptimalSolution.values``.
    """
    n = len(rho)

    @functools.lru_cache(maxsize=None)
    def val(r, c, e, item, t):
        if t == 0:
            return 0.0
        best = 0.0
        for dr, dc in MOVES:
            nr, nc = min(max(r + dr, 0), n - 1), min(max(c + dc, 0), n - 1)
            if (nr, nc) == item:  # collected before the risk draw
                q = 1.0
            else:
                ne = big_e if (nr, nc) == (0, 0) else e - 1
                q = 0.0 if ne <= 0 else gamma * (1.0 - rho[nr][nc]) * val(nr, nc, ne, item, t - 1)
            best = max(best, q)
        return best

    out = np.zeros((n * n, big_e + 1, n * n))
    for p in range(n * n):
        for e in range(1, big_e + 1):
            for i in range(n * n):
                out[p, e, i] = val(p // n, p % n, e, divmod(i, n), horizon)
    return out


def _random_risk(n, seed):
    rng = np.random.default_rng(seed)
    rho = rng.uniform(0.05, 0.6, (n, n))
    rho[0, 0] = 0.0
    return rho


@pytest.mark.parametrize("n,big_e,gamma", [(2, 2, 1.0), (3, 3, 1.0), (3, 4, 0.9)])
def test_values_match_brute_force(n, big_e, gamma):
    rho = _random_risk(n, seed=n * 10 + big_e)
    sol = solve_single_item(rho, big_e, 1, gamma=gamma, tol=1e-12)
    ref = brute_force_values(rho.tolist(), big_e, horizon=30, gamma=gamma)
    np.testing.assert_allclose(sol.values, ref, atol=1e-9)
    assert sol.values.shape == (n * n, big_e + 1, n * n)
    assert sol.policy.dtype == np.int32
    # the greedy action attains the value (one-step lookahead with the brute-force values)
    p, e, i = 1, big_e, n * n - 1
    a = int(sol.policy[p, e, i])
    nr, nc = [min(max(x + d, 0), n - 1) for x, d in zip(divmod(p, n), MOVES[a])]
    q = 1.0 if nr * n + nc == i else gamma * (1 - rho[nr, nc]) * ref[nr * n + nc, big_e if nr == nc == 0 else e - 1, i]
    assert q == pytest.approx(ref[p, e, i], abs=1e-9)


def test_expected_optimum_distributions():
    n, big_e, e0 = 3, 3, 2
    rho = _random_risk(n, seed=5)
    sol = solve_single_item(rho, big_e, e0)
    v = sol.values[:, e0, :]
    free = np.mean([np.mean([v[p, i] for p in range(n * n) if p != i]) for i in range(n * n)])
    assert expected_optimum(sol) == pytest.approx(free)
    assert expected_optimum(sol, start="base") == pytest.approx(v[0].mean())
    assert expected_optimum(sol, items_on_base=False, start="random") == pytest.approx(v[:, 1:].mean())
    # an agent standing on the item at reset collects it by staying
    assert np.all(np.diagonal(v) == 1.0)
    with pytest.raises(ValueError, match="start"):
        expected_optimum(sol, start="nowhere")


@pytest.mark.parametrize(
    "bad,match",
    [
        ((16.5, 8), "max_energy"),
        ((16, 8.5), "init_energy"),
        ((math.inf, 8), "max_energy"),
        ((16, math.inf), "init_energy"),
        ((16, 0), "init_energy"),
        ((16, math.nan), "init_energy"),
        ((8, 16), "must not exceed"),
        ((True, 1), "max_energy"),
    ],
)
def test_validation(bad, match):
    with pytest.raises(ValueError, match=match):
        solve_single_item("high", *bad)


def test_gamma_validation():
    with pytest.raises(ValueError, match="gamma"):
        solve_single_item("high", 4, 2, gamma=0.0)


@pytest.fixture(scope="module")
def table48():
    """The Table 4.8 setting: 8x8, high risk, energy 8/16, one item of reward one."""
    env = DCP(total_reward=1, idle_terminates=True)
    params = env.make_params("high", (8.0, 16.0))
    return env, params, solve_single_item("high", 16, 8)


def _mean_se(final_states):
    s = summarize(final_states)
    return s["reward"]["mean"], s["reward"]["sd"] / math.sqrt(s["episodes"])


def test_optimal_policy_simulation_matches_optimum(table48):
    env, params, sol = table48
    opt = expected_optimum(sol)
    finals = jax.jit(lambda k: run_episodes(env, params, optimal_policy(sol), k, 4000))(jax.random.key(7))
    mean, se = _mean_se(finals)
    assert abs(mean - opt) <= 4 * se + 1e-9, (mean, opt, se)
    assert summarize(finals)["outcomes"]["idle"] == 0  # the greedy policy never loops in the base


def test_optimum_bounds_navigators(table48):
    env, params, sol = table48
    opt = expected_optimum(sol)
    for k, name in enumerate(navigators.NAVIGATORS):
        mean, se = _mean_se(evaluate_heuristic(env, params, name, jax.random.key(100 + k), episodes=2000))
        assert mean <= opt + 4 * se, (name, mean, opt, se)


def test_small_grid_simulation(start="random", items_on_base=False):
    env = DCP(grid_size=3, total_reward=1, start=start, items_on_base=items_on_base)
    rho = _random_risk(3, seed=11).astype(np.float32)
    params = env.make_params(rho, (2.0, 3.0))
    sol = solve_single_item(rho, 3, 2)
    opt = expected_optimum(sol, items_on_base=items_on_base, start=start)
    finals = jax.jit(lambda k: run_episodes(env, params, optimal_policy(sol), k, 4000))(jax.random.key(3))
    mean, se = _mean_se(finals)
    assert abs(mean - opt) <= 4 * se + 1e-9, (mean, opt, se)


def test_evaluate_optimal_is_a_named_record():
    env = DCP(grid_size=3, total_reward=1, start="base")
    rho = _random_risk(3, seed=5).astype(np.float32)
    params = env.make_params(rho, (2.0, 3.0))
    got = evaluate_optimal(env, params, jax.random.key(1), 50)
    assert isinstance(got, OptimalEvaluation)
    assert got.expected_optimum == pytest.approx(expected_optimum(solve_single_item(rho, 3, 2), start="base"))
    assert np.asarray(got.final.ep_reward).shape == (50,)
    final, optimum = got  # still unpacks as (final states, expected optimum)
    assert optimum == got.expected_optimum
    with pytest.raises(ValueError, match="total_reward=1"):
        evaluate_optimal(DCP(grid_size=3, total_reward=2), params, jax.random.key(1), 5)
