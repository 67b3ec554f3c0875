"""The six builders against the plain-Python transcription of Eqs. 3.2-3.8."""

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.drp import tours, world
from tests.support import drp_reference as ref

N = 7


def graphs(count, seed0=0):
    out = []
    for s in range(count):
        g = world.generate(seed0 + s, n=N, size=40, rewards="1-9", alpha=float(5 * (s % 6)))
        out.append(g)
    return out


@pytest.mark.parametrize("builder", tours.BUILDERS)
def test_builder_matches_transcription(builder):
    gs = graphs(8)
    arrs = [world.arrays(g) for g in gs]
    D = jnp.stack([a[0] for a in arrs])
    beta = jnp.stack([a[1] for a in arrs])
    psi = jnp.full((len(gs),), 0.99, jnp.float32)
    rng = np.random.default_rng(0)
    masks = rng.random((len(gs), N + 1)) < 0.8
    masks[:4] = True  # full clusters and random sub-clusters
    masks[:, 0] = False
    masks[:, 1] = True
    got_t, got_r = tours.build_tours_batch(builder, D, beta, psi, jnp.asarray(masks))
    for i in range(len(gs)):
        Dl, bl = np.asarray(D[i], float).tolist(), np.asarray(beta[i], float).tolist()
        C = list(np.flatnonzero(masks[i]))
        want = ref.build_tour(builder, Dl, bl, 0.99, C)
        assert [int(v) for v in got_t[i] if v >= 0] == want, (builder, i)
        assert float(got_r[i]) == pytest.approx(ref.tour_reward(Dl, bl, 0.99, want), rel=1e-4, abs=1e-4)


def test_single_graph_equals_batched_and_is_deterministic():
    g = graphs(1, 11)[0]
    D, beta, psi = world.arrays(g)
    mask = jnp.ones(N + 1, bool).at[0].set(False)
    t1, r1 = tours.build_tour_jit("gi", D, beta, psi, mask)
    t2, r2 = tours.build_tour_jit("gi", D, beta, psi, mask)
    tb, rb = tours.build_tours_batch("gi", D[None], beta[None], psi[None], mask[None])
    assert np.array_equal(t1, t2) and np.array_equal(t1, tb[0]) and float(r1) == float(rb[0])
    assert sorted(int(v) for v in t1) == list(range(1, N + 1))


def test_gi_scores_are_eq_3_8():
    g = graphs(1, 5)[0]
    D, beta, psi = world.arrays(g)
    Dl, bl = np.asarray(D, float).tolist(), np.asarray(beta, float).tolist()
    t = [3, 1, 6]
    cycle = jnp.asarray([0] + t + [0] * (N - len(t)), jnp.int32)
    mask = jnp.asarray([v not in t and v != 0 for v in range(N + 1)])
    s = np.asarray(jax.jit(tours.gi_scores)(psi ** D, beta, cycle, len(t), mask))
    base = ref.rho(Dl, bl, 0.99, t, cyclic=True)
    for u in range(1, N + 1):
        for i in range(len(t) + 1):
            if u in t:
                assert s[i, u] == -np.inf
            else:
                want = ref.rho(Dl, bl, 0.99, t[:i] + [u] + t[i:], cyclic=True) - base
                assert s[i, u] == pytest.approx(want, rel=1e-4, abs=1e-4)
    assert (s[len(t) + 1:] == -np.inf).all()


def test_unknown_builder():
    with pytest.raises(ValueError, match="builder must be one of"):
        tours.build_tour("xx", jnp.zeros((2, 2)), jnp.zeros(2), 0.99, jnp.ones(2, bool))


_trajectory = jax.jit(tours.gi_trajectory, static_argnums=4)
_gi_resume = jax.jit(lambda D, beta, psi, mask, cycle0, m0: tours.build_order("gi", psi ** D, beta, mask, (cycle0, m0)))


def _resumed(D, beta, union, cycles, first, extra):
    """GI over ``union`` resumed from the trajectory of the cluster, as NC does it."""
    d = int(np.min(np.asarray(first)[extra]))
    cyc = np.asarray(cycles[d])
    rest = union.copy()
    rest[cyc] = False
    return d, [int(v) for v in _gi_resume(D, beta, jnp.float32(0.99), jnp.asarray(rest), jnp.asarray(cyc), d) if v >= 0]


def test_gi_resumed_from_trajectory_equals_fresh_build():
    # GI's score depends on the partial tour only: over C ∪ C', GI follows GI over C until a node of C'
    # first cuts in (gi_trajectory's `first`), so resuming there gives the same tour as building from scratch.
    saved = 0
    for seed in range(6):
        g = world.generate(seed, n=N, size=40, rewards="1-9", alpha=float(10 * (seed % 4)))
        D, beta, _ = world.arrays(g)
        rng = np.random.default_rng(seed)
        cluster = np.zeros(N + 1, bool)
        cluster[1 + rng.permutation(N)[: 2 + seed % 3]] = True
        cycles, first = _trajectory(D, beta, jnp.float32(0.99), jnp.asarray(cluster), N)
        outside = np.flatnonzero(~cluster[1:]) + 1
        extras = [[v] for v in outside] + [list(rng.choice(outside, 2, replace=False)), list(outside)]
        for extra in extras:
            union = cluster.copy()
            union[extra] = True
            want = [int(v) for v in tours.build_tour_jit("gi", D, beta, jnp.float32(0.99), jnp.asarray(union))[0]
                    if v >= 0]
            d, got = _resumed(D, beta, union, cycles, first, extra)
            assert got == want, (seed, extra, d)
            saved += d
    assert saved > 0  # the trajectory did skip insertions


def test_gi_trajectory_breaks_ties_like_a_fresh_build():
    # Nodes 1 and 2 mirror each other about the base: equal scores at step 0. A fresh GI over {1, 2} inserts
    # node 1 first (lowest index), so node 1 must cut into the trajectory of {2} at step 0, while node 2
    # must not cut into that of {1} (equal score, higher index).
    g = world.Graph(np.array([50.0, 50.0]), np.array([[40.0, 50.0], [60.0, 50.0], [50.0, 30.0], [50.0, 70.0]]),
                    np.array([5.0, 5.0, 5.0, 5.0]), 0.99, 20.0)
    D, beta, _ = world.arrays(g)
    two = np.array([False, False, True, False, False])
    _, first = _trajectory(D, beta, jnp.float32(0.99), jnp.asarray(two), 4)
    assert int(first[1]) == 0
    one = np.array([False, True, False, False, False])
    _, first = _trajectory(D, beta, jnp.float32(0.99), jnp.asarray(one), 4)
    assert int(first[2]) == 1  # ties with node 1 at step 0 but loses on index; then the cluster is done
    for cluster, extra in ((two, [1]), (one, [2])):
        cycles, first = _trajectory(D, beta, jnp.float32(0.99), jnp.asarray(cluster), 4)
        union = cluster.copy()
        union[extra] = True
        want = [int(v) for v in tours.build_tour_jit("gi", D, beta, jnp.float32(0.99), jnp.asarray(union))[0] if v >= 0]
        assert _resumed(D, beta, union, cycles, first, extra)[1] == want


@pytest.mark.parametrize("builder", ["osa", "gml", "gi"])
def test_phased_builds_equal_single_phase_builds(builder):
    # Above K = 32 OSA, GML and GI run in quarters on compacted columns (tours._append_phases, tours._gi_phases);
    # the same clusters padded to K = 24 (fewer phases, all columns) must give the same tours.
    g = world.generate(4, n=40, size=60, rewards="5", alpha=20.0)  # equal rewards: many exact ties
    D, beta, psi = world.arrays(g)
    P = psi ** D
    rng = np.random.default_rng(1)
    clusters = [np.sort(rng.choice(np.arange(1, 41), size, replace=False)) for size in (5, 13, 24, 24)]
    build = jax.jit(jax.vmap(lambda P, beta, mask: tours.build_order(builder, P, beta, mask)))
    small, big = [], []
    for K, out in ((24, small), (40, big)):
        subs = np.stack([np.concatenate([[0], c, np.zeros(K - len(c), int)]) for c in clusters])
        masks = np.arange(K + 1)[None, :] <= np.array([len(c) for c in clusters])[:, None]
        got = np.asarray(build(P[subs[:, :, None], subs[:, None, :]], beta[subs], jnp.asarray(masks)))
        out.extend([[int(sub[v]) for v in t if v >= 0] for sub, t in zip(subs, got)])
    assert small == big
    phases = tours._gi_phases if builder == "gi" else partial(tours._append_phases, builder)
    assert len(phases(40)) == 4 and len(phases(24)) == (2 if builder == "gi" else 1)
