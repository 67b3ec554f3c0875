"""NC (Algorithm 1 with a builder, Algorithm 5) and PGC (Algorithms 3-4) against the transcription."""

import jax.numpy as jnp
import numpy as np
import pytest

import drp_reference as ref
from jaxdc.drp import clustering as cl
from jaxdc.drp import world

N = 7
ALPHAS = [0.0, 10.0, 25.0, 40.0]


def batch(seeds, rewards="1-9"):
    gs = [world.generate(s, n=N, size=40, rewards=rewards) for s in seeds]
    D = jnp.stack([world.distances(g.base, g.nodes) for g in gs])
    beta = jnp.stack([world.node_values(g.rewards, 0.0) for g in gs])
    return D, beta, jnp.full((len(gs),), 0.99, jnp.float32)


@pytest.mark.parametrize("builder", ["ng", "tl", "gi"])
def test_nc_matches_transcription_and_never_merges_on_nonpositive_gain(builder):
    seeds = [0, 1, 2]
    D, beta, psi = batch(seeds)
    gidx = np.repeat(np.arange(len(seeds)), len(ALPHAS))
    alpha = np.tile(ALPHAS, len(seeds))
    member = cl.nc(builder, D, beta, psi, gidx, alpha)
    for i, (g, a) in enumerate(zip(gidx, alpha)):
        Dl = np.asarray(D[g], float).tolist()
        bl = [a] + np.asarray(beta[g], float).tolist()[1:]
        R = lambda C: ref.tour_reward(Dl, bl, 0.99, ref.build_tour(builder, Dl, bl, 0.99, C))
        got = [list(map(int, c)) for c in cl.clusters_from_member(member[i])]
        assert got == ref.nc(Dl, bl, 0.99, R), (builder, g, a)
        assert sorted(v for c in got for v in c) == list(range(1, N + 1))
        # Final state: no pair has a positive merge gain (the loop stopped correctly) ...
        for x in range(len(got)):
            for y in range(x + 1, len(got)):
                assert R(got[x] + got[y]) - R(got[x]) - R(got[y]) <= 1e-4
        # ... and with alpha = 0 every merge gain is <= 0 (triangle inequality): all singletons.
        if a == 0:
            assert len(got) == N


def test_pgc_matches_transcription():
    for seed in range(4):
        for a in ALPHAS:
            g = world.generate(seed, n=8, size=40, rewards="4-6", alpha=a)
            D, beta, _ = world.arrays(g)
            Dl, bl = np.asarray(D, float).tolist(), np.asarray(beta, float).tolist()
            clusters, records, _ = cl.pgc(np.asarray(D, float), np.asarray(beta, float), 0.99, a)
            want = ref.pgc(Dl, bl, 0.99, a)
            assert clusters == [r["C"] for r in want]
            for (e, l, gg, c), r in zip(records, want):
                assert (e, l, gg, c) == pytest.approx((r["e"], r["l"], r["g"], r["c"]))


def test_pgc_kmst_bookkeeping_against_direct_computation():
    g = world.generate(3, n=30, size=60, alpha=30.0)
    D, beta, _ = world.arrays(g)
    Dn = np.asarray(D, float)
    clusters, records, edges = cl.pgc(Dn, np.asarray(beta, float), 0.99, 30.0)
    assert len(clusters) < 30  # something merged
    for C, (e, l, gain, c) in zip(clusters, records):
        mine = [(u, v) for u, v in edges if u in C]
        assert all(v in C for _, v in mine)
        # a spanning tree of C: |C| - 1 edges, connected
        assert len(mine) == len(C) - 1
        seen, todo = {C[0]}, [C[0]]
        while todo:
            x = todo.pop()
            for u, v in mine:
                for a, b in ((u, v), (v, u)):
                    if a == x and b not in seen:
                        seen.add(b)
                        todo.append(b)
        assert seen == set(C)
        # l is the total edge length of that tree, the entry is the member closest to the base
        assert l == pytest.approx(sum(Dn[u, v] for u, v in mine))
        assert e == C[int(np.argmin(Dn[0, C]))]
        if len(C) == 1:
            assert gain == pytest.approx(0.99 ** Dn[0, e] * float(beta[e]))
            assert c == pytest.approx((1 - 0.99 ** (2 * Dn[0, e])) * 30.0)


def test_pgc_merge_of_two_singletons_is_the_exact_two_node_tour():
    g = world.generate(2, n=2, size=30, alpha=12.0)
    D, beta, _ = world.arrays(g)
    clusters, records, _ = cl.pgc(np.asarray(D, float), np.asarray(beta, float), 0.99, 12.0)
    Dl, bl = np.asarray(D, float).tolist(), np.asarray(beta, float).tolist()
    if len(clusters) == 1:
        e, l, gain, c = records[0]
        other = 3 - e
        assert gain - c == pytest.approx(ref.tour_reward(Dl, bl, 0.99, [e, other]), rel=1e-6)


def test_plan_tours_drops_unprofitable_robots():
    D, beta, psi = batch([0])
    res = cl.plan_tours("ng", D, beta, psi, np.array([0, 0]), np.array([0.0, 500.0]),
                        [[[v] for v in range(1, N + 1)]] * 2)
    assert len(res[0][1]) == N and res[0][0] > 0
    assert res[1] == (0.0, [])


@pytest.mark.parametrize("builder", ["ng", "lpg", "gi"])  # the cache serves all append builders alike
def test_nc_tour_cache_gives_the_same_clusters_and_plans(builder):
    """The append-builder tour cache (shared across robot values and rounds) changes nothing."""
    seeds = [3, 4, 5]
    n = 10
    gs = [world.generate(s, n=n, size=40, rewards="1-9") for s in seeds]
    D = jnp.stack([world.distances(g.base, g.nodes) for g in gs])
    beta = jnp.stack([world.node_values(g.rewards, 0.0) for g in gs])
    psi = jnp.full((len(gs),), 0.99, jnp.float32)
    alphas = [0.0, 5.0, 10.0, 20.0, 30.0, 45.0, 60.0]
    gidx = np.repeat(np.arange(len(seeds)), len(alphas))
    alpha = np.tile(np.asarray(alphas, np.float32), len(seeds))
    cached = cl.nc(builder, D, beta, psi, gidx, alpha)
    plain = cl.nc(builder, D, beta, psi, gidx, alpha, cache=False)
    np.testing.assert_array_equal(cached, plain)
    merged = (cached.sum(2) > 1).any()
    assert merged  # the check is not vacuous: some instance merged clusters
    clusters = [cl.clusters_from_member(m) for m in cached]
    a = cl.plan_tours(builder, D, beta, psi, gidx, alpha, clusters)
    b = cl.plan_tours(builder, D, beta, psi, gidx, alpha, [cl.clusters_from_member(m) for m in plain])
    np.testing.assert_array_equal([r for r, _ in a], [r for r, _ in b])
    assert [t for _, t in a] == [t for _, t in b]
    if builder != "gi":
        # The cached rewards themselves: R(C) from (collected, p_return) matches the direct build.
        rng = np.random.default_rng(0)
        masks = rng.random((64, n + 1)) < 0.5
        masks[:, 0] = False
        masks[~masks.any(1), 1] = True
        gg = rng.integers(0, len(seeds), 64)
        aa = rng.choice(np.asarray(alphas, np.float32), 64)
        direct = cl.evaluate_clusters(builder, D, beta, psi, gg, aa, masks)
        c, p = cl.evaluate_parts(builder, D, beta, psi, gg.astype(np.int32), masks)
        np.testing.assert_array_equal(cl._combine(c, p, aa), direct)  # the same float64 computation


def test_nc_gi_resume_gives_the_same_clusters_as_rebuilding():
    D, beta, psi = batch([3, 4], rewards="4-6")
    gidx = np.repeat(np.arange(2), len(ALPHAS))
    alpha = np.tile(ALPHAS, 2)
    fast = cl.nc("gi", D, beta, psi, gidx, alpha, resume=True)
    slow = cl.nc("gi", D, beta, psi, gidx, alpha, resume=False)
    assert (fast == slow).all()
    assert any(len(cl.clusters_from_member(m)) < N for m in fast)  # merges happened


def test_cluster_rewards_do_not_depend_on_the_batch():
    # R(C) comes from the tour, in float64 on the host: the same cluster alone, in a batch of its bucket, or
    # in a batch spread over many buckets gets exactly the same reward (XLA's float32 results can differ
    # with the compiled program and the batch width).
    D, beta, psi = batch([6, 7], rewards="1-9")
    rng = np.random.default_rng(2)
    masks = rng.random((300, N + 1)) < 0.6
    masks[:, 0] = False
    masks[~masks.any(1), 3] = True
    gidx = rng.integers(0, 2, 300)
    alpha = rng.choice(np.asarray(ALPHAS, np.float32), 300)
    for builder in ("tl", "gi"):
        together = cl.evaluate_clusters(builder, D, beta, psi, gidx, alpha, masks)
        for j in (0, 17, 299):
            alone = cl.evaluate_clusters(builder, D, beta, psi, gidx[j:j + 1], alpha[j:j + 1], masks[j:j + 1])
            assert alone[0] == together[j]
        assert together.dtype == np.float64
        # ... and they are Eq. 3.1 of the tour (float32 jax computation, to float32 precision).
        rewards, tours = cl.evaluate_clusters(builder, D, beta, psi, gidx, alpha, masks, with_tours=True)
        for j in (0, 17, 299):
            b = beta[gidx[j]].at[0].set(alpha[j])
            want = float(world.tour_reward(D[gidx[j]], b, psi[gidx[j]], jnp.asarray(tours[j])))
            assert rewards[j] == pytest.approx(want, rel=1e-5, abs=1e-4)
