"""Tests of the all-pairs safest paths (section 4.4.1, Fig. 4.2) in jaxdc.core.paths."""

from __future__ import annotations

from collections import deque

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from jaxdc.core import grid, paths

safest = jax.jit(paths.safest_paths, static_argnames=("path_risk",))
TOL = 1e-6


# ----------------------------------------------------------------------------
# numpy / scipy references (float64)
# ----------------------------------------------------------------------------


def _moves(n):
    """succ[c, a-1] for the 8 moves a = 1..8, and validity (not a self-loop)."""
    r, c = np.divmod(np.arange(n * n), n)
    d = grid.DELTAS_NP[1:]
    succ = np.clip(r[:, None] + d[:, 0], 0, n - 1) * n + np.clip(c[:, None] + d[:, 1], 0, n - 1)
    return succ, succ != np.arange(n * n)[:, None]


def _weights(risk, path_risk):
    n = risk.shape[0]
    succ, valid = _moves(n)
    with np.errstate(divide="ignore"):
        lw = -np.log1p(-risk.reshape(-1).astype(np.float64))
    w = np.broadcast_to(lw[:, None], succ.shape) if path_risk == "departed" else lw[succ]
    return succ, valid, w


def ref_cost(risk, path_risk):
    """cost[c, b] by scipy's Dijkstra (infinite edges left out)."""
    n = risk.shape[0]
    succ, valid, w = _weights(risk, path_risk)
    keep = valid & np.isfinite(w)
    rows = np.repeat(np.arange(n * n), 8).reshape(n * n, 8)
    # Duplicate (u, v) edges carry the same weight; keep one of each.
    pairs = {}
    for u, v, ww in zip(rows[keep], succ[keep], w[keep]):
        pairs[(u, v)] = ww
    u, v = np.array(list(pairs)).T
    g = sp.csr_matrix((np.array(list(pairs.values())), (u, v)), shape=(n * n, n * n))
    return dijkstra(g, directed=True)


def ref_steps(risk, path_risk, cost, tie_tol=TOL):
    """Fewest moves to b using only cost-tight moves (BFS over the tight DAG), float64."""
    n = risk.shape[0]
    m = n * n
    succ, valid, w = _weights(risk, path_risk)
    steps = np.full((m, m), -1)
    for b in range(m):
        mc = np.where(valid, w + cost[succ, b], np.inf)
        q = mc.min(axis=1, keepdims=True)
        tol = np.where(np.isfinite(q), tie_tol * (1 + q), 0.0)
        with np.errstate(invalid="ignore"):
            tight = valid & ((mc == q) | (np.abs(mc - q) <= tol))
        preds = [[] for _ in range(m)]
        for c in range(m):
            for a in range(8):
                if tight[c, a]:
                    preds[succ[c, a]].append(c)
        steps[b, b] = 0
        dq = deque([b])
        while dq:
            v = dq.popleft()
            for u in preds[v]:
                if steps[u, b] < 0:
                    steps[u, b] = steps[v, b] + 1
                    dq.append(u)
    return steps


def follow(risk, table, path_risk, c, b):
    """Walk next_action from c; return (moves, product of (1 - risk) over the paid cells)."""
    n = risk.shape[0]
    flat = risk.reshape(-1)
    na = np.asarray(table.next_action)
    pos, k, prob = c, 0, 1.0
    while pos != b:
        a = int(na[pos, b])
        assert 1 <= a <= 8, (c, b, pos, a)
        rc = np.array(divmod(pos, n))
        nxt = np.clip(rc + grid.DELTAS_NP[a], 0, n - 1)
        nxt = int(nxt[0] * n + nxt[1])
        assert nxt != pos, "next_action must not be a clipped self-loop"
        prob *= 1.0 - (flat[pos] if path_risk == "departed" else flat[nxt])
        pos, k = nxt, k + 1
        assert k <= n * n, "following next_action does not reach the target"
    return k, prob


def random_maps(n, rng):
    tied = rng.choice([0.0, 0.01, 0.04], size=(n, n))
    tied[0, 0] = 0.0
    cont = rng.uniform(0.0, 0.9, size=(n, n))
    const = np.full((n, n), 0.05)
    zero = np.zeros((n, n))
    return [tied, cont, const, zero]


# ----------------------------------------------------------------------------
# tests
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("path_risk", paths.PATH_RISK)
@pytest.mark.parametrize("n", [2, 3, 5, 8])
def test_against_scipy_steps_and_following(n, path_risk):
    rng = np.random.default_rng(100 + n)
    for risk in random_maps(n, rng) + [grid.risk_map("high", n)]:
        risk = np.asarray(risk, dtype=np.float32)
        t = safest(risk, path_risk=path_risk)
        succ_p = np.asarray(t.success)
        cost = ref_cost(risk.astype(np.float64), path_risk)
        np.testing.assert_allclose(succ_p, np.exp(-cost), rtol=1e-5, atol=1e-6)
        np.testing.assert_array_equal(np.diag(succ_p), 1.0)
        steps = np.asarray(t.steps)
        np.testing.assert_array_equal(steps, ref_steps(risk, path_risk, cost))
        na = np.asarray(t.next_action)
        np.testing.assert_array_equal(np.diag(na), grid.STAY)
        m = n * n
        pairs = [(c, b) for c in range(m) for b in range(m)] if m <= 25 else [
            tuple(p) for p in rng.integers(0, m, size=(150, 2))
        ]
        for c, b in pairs:
            k, prob = follow(risk, t, path_risk, c, b)
            assert k == steps[c, b]
            np.testing.assert_allclose(prob, succ_p[c, b], rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("path_risk", paths.PATH_RISK)
def test_uniform_map_is_fewest_moves(path_risk):
    n = 8
    risk = np.full((n, n), 0.1, dtype=np.float32)
    risk[0, 0] = 0.0
    t = safest(risk, path_risk=path_risk)
    coords = np.asarray(grid.cell_coords(n))
    cheb = np.abs(coords[:, None] - coords[None]).max(-1)
    np.testing.assert_array_equal(np.asarray(t.steps), cheb)
    # Paid cells = moves, minus one where the free base lies on a shortest path as a paid cell.
    via_base = cheb[:, :1] + cheb[:1, :] == cheb
    base_paid = np.ones_like(cheb, dtype=bool)
    if path_risk == "departed":
        base_paid[:, 0] = False  # the target is never departed
    else:
        base_paid[0, :] = False  # the source is never entered
    paid = cheb - (via_base & base_paid & (cheb > 0))
    np.testing.assert_allclose(np.asarray(t.success), 0.9 ** paid, rtol=1e-5)
    f = lambda r, c: r * n + c  # noqa: E731
    na = np.asarray(t.next_action)
    assert na[f(3, 3), f(5, 5)] == grid.ACTIONS.index("down_right")  # the only shortening move
    # down, down_left and down_right all shorten: the lowest index (down) wins.
    assert na[f(3, 3), f(5, 3)] == grid.ACTIONS.index("down")
    assert na[f(7, 7), f(7, 3)] == grid.ACTIONS.index("left")


def test_fig41b_high_risk_map_hand_checked():
    risk = grid.risk_map("high", 8)
    f = lambda r, c: r * 8 + c  # noqa: E731
    dep = safest(risk, path_risk="departed")
    ent = safest(risk, path_risk="entered")
    # Base -> (0, 7) along the top border: departs the free base and 6 border cells.
    s, a, k = paths.path_to(dep, f(0, 0), f(0, 7))
    np.testing.assert_allclose(s, 0.99**6, rtol=1e-6)
    assert (int(a), int(k)) == (grid.ACTIONS.index("right"), 7)
    # (7, 7) -> base around the border, cutting the (7, 0) corner: 13 border cells departed;
    # going up first and going left first tie exactly, "up" has the lower index.
    s, a, k = paths.path_to(dep, f(7, 7), f(0, 0))
    np.testing.assert_allclose(s, 0.99**13, rtol=1e-6)
    assert (int(a), int(k)) == (grid.ACTIONS.index("up"), 13)
    # From the centre (3, 3) to the base: the diagonal (2, 2) [0.16], (1, 1) [0.04], base.
    s, a, k = paths.path_to(ent, f(3, 3), f(0, 0))
    np.testing.assert_allclose(s, 0.84 * 0.96, rtol=1e-6)
    assert (int(a), int(k)) == (grid.ACTIONS.index("up_left"), 3)
    s, a, k = paths.path_to(dep, f(3, 3), f(0, 0))
    np.testing.assert_allclose(s, 0.36 * 0.84 * 0.96, rtol=1e-6)
    assert (int(a), int(k)) == (grid.ACTIONS.index("up_left"), 3)
    # Safest is not shortest: base -> (7, 7) skirts the centre.
    assert int(dep.steps[0, f(7, 7)]) > 7
    np.testing.assert_allclose(dep.success[0, f(7, 7)], 0.99**12, rtol=1e-6)


@pytest.mark.parametrize("path_risk", paths.PATH_RISK)
def test_risk_one_wall(path_risk):
    n = 5
    risk = np.full((n, n), 0.02, dtype=np.float32)
    risk[0, 0] = 0.0
    risk[:, 2] = 1.0  # a wall every path between the left and the right half must cross
    t = safest(risk, path_risk=path_risk)
    for field in (t.success, t.next_action, t.steps):
        assert np.all(np.isfinite(np.asarray(field, dtype=np.float64)))
    s = np.asarray(t.success)
    cols = np.arange(n * n) % n
    left, wall, right = cols < 2, cols == 2, cols > 2
    assert np.all(s[np.ix_(left, right)] == 0) and np.all(s[np.ix_(right, left)] == 0)
    assert np.all(s[np.ix_(left, left)] > 0)
    if path_risk == "departed":
        assert np.all(s[np.ix_(wall, ~wall)] == 0) and np.all(s[np.ix_(left, wall)] > 0)
    else:
        assert np.all(s[np.ix_(~wall, wall)] == 0) and np.all(s[np.ix_(wall, left)] > 0)
    cost = ref_cost(risk.astype(np.float64), path_risk)
    np.testing.assert_allclose(s, np.exp(-cost), rtol=1e-5, atol=1e-7)
    np.testing.assert_array_equal(np.asarray(t.steps), ref_steps(risk, path_risk, cost))
    for c in range(n * n):
        for b in range(n * n):
            k, prob = follow(risk, t, path_risk, c, b)
            assert k == t.steps[c, b]
            np.testing.assert_allclose(prob, s[c, b], rtol=1e-5, atol=1e-7)


def test_vmap_batch_and_determinism():
    rng = np.random.default_rng(7)
    maps = rng.choice([0.0, 0.01, 0.04, 0.2], size=(3, 5, 5)).astype(np.float32)
    maps[:, 0, 0] = 0.0
    batched = jax.jit(jax.vmap(lambda r: paths.safest_paths(r, "entered")))(maps)
    assert batched.success.shape == (3, 25, 25)
    for i in range(3):
        single = safest(maps[i], path_risk="entered")
        for name in ("success", "next_action", "steps"):
            np.testing.assert_array_equal(getattr(batched, name)[i], getattr(single, name))
    again = safest(maps[0], path_risk="entered")
    small = maps[0, :3, :3]
    eager = paths.safest_paths(jnp.asarray(small), path_risk="entered")
    jitted = safest(small, path_risk="entered")
    for name in ("success", "next_action", "steps"):
        np.testing.assert_array_equal(getattr(again, name), getattr(batched, name)[0])
        np.testing.assert_array_equal(getattr(eager, name), getattr(jitted, name))
    assert again.success.dtype == jnp.float32
    assert again.next_action.dtype == jnp.int32 and again.steps.dtype == jnp.int32


@pytest.mark.parametrize("path_risk", paths.PATH_RISK)
def test_coarse_tie_tol(path_risk):
    """A large tie_tol makes near-equal paths ties: fewer moves win, costs stay exact."""
    n, tie_tol = 6, 0.03
    rng = np.random.default_rng(11)
    for _ in range(3):
        risk = rng.choice([0.0, 0.0, 0.01, 0.02, 0.03, 0.05], size=(n, n)).astype(np.float32)
        t = safest(risk, path_risk=path_risk, tie_tol=tie_tol)
        cost = ref_cost(risk.astype(np.float64), path_risk)
        np.testing.assert_allclose(np.asarray(t.success), np.exp(-cost), rtol=1e-5, atol=1e-6)
        steps = np.asarray(t.steps)
        np.testing.assert_array_equal(steps, ref_steps(risk, path_risk, cost, tie_tol))
        exact = ref_steps(risk, path_risk, cost)
        assert np.all(steps <= exact) and np.any(steps < exact)
        for c in range(n * n):
            for b in range(n * n):
                k, _ = follow(risk, t, path_risk, c, b)
                assert k == steps[c, b]


def test_bad_path_risk_and_shape():
    with pytest.raises(ValueError, match="path_risk.*departed.*entered"):
        paths.safest_paths(np.zeros((3, 3)), path_risk="both")
    with pytest.raises(ValueError, match="path_risk"):
        safest(np.zeros((3, 3)), path_risk="exited")
    with pytest.raises(ValueError, match="square"):
        paths.safest_paths(np.zeros((3, 4)))


def test_helpers():
    assert int(grid.flat_index(jnp.array([2, 3]), 5)) == 13
    np.testing.assert_array_equal(grid.flat_index(np.array([[0, 0], [4, 4], [1, 0]]), 5), [0, 24, 5])
    t = safest(grid.risk_map("medium", 4), path_risk="departed")
    s, a, k = paths.path_to(t, jnp.array([0, 5]), jnp.array([15, 5]))
    np.testing.assert_array_equal(s, t.success[jnp.array([0, 5]), jnp.array([15, 5])])
    np.testing.assert_array_equal(np.asarray(k), [int(t.steps[0, 15]), 0])
    assert int(a[1]) == grid.STAY and float(s[1]) == 1.0
    # jit + vmap of path_to over sources
    f = jax.jit(jax.vmap(paths.path_to, in_axes=(None, 0, None)))
    s2, _, _ = f(t, jnp.arange(16), 0)
    np.testing.assert_array_equal(s2, t.success[:, 0])
