"""NC (Algorithm 1 with a builder, Algorithm 5) against the transcription, and the plans of its clusters."""

import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.drp import world
from jaxdc.drp.evaluate import combine, evaluate_clusters, evaluate_parts
from jaxdc.drp.nc_clustering import nc
from jaxdc.drp.plans import clusters_from_member, plan_tours
from tests.support import drp_reference as ref
from tests.support.drp_reference import graph_batch

N = 7
ALPHAS = [0.0, 10.0, 25.0, 40.0]


def batch(seeds, rewards="1-9"):
    return graph_batch(seeds, N, rewards)


@pytest.mark.parametrize("builder", ["ng", "tl", "gi"])
def test_nc_matches_transcription_and_never_merges_on_nonpositive_gain(builder):
    seeds = [0, 1, 2]
    D, beta, psi = batch(seeds)
    gidx = np.repeat(np.arange(len(seeds)), len(ALPHAS))
    alpha = np.tile(ALPHAS, len(seeds))
    member = nc(builder, D, beta, psi, gidx, alpha)
    for i, (g, a) in enumerate(zip(gidx, alpha)):
        Dl = np.asarray(D[g], float).tolist()
        bl = [a] + np.asarray(beta[g], float).tolist()[1:]
        def R(C, Dl=Dl, bl=bl):  # this iteration's instance
            return ref.tour_reward(Dl, bl, 0.99, ref.build_tour(builder, Dl, bl, 0.99, C))

        got = [list(map(int, c)) for c in clusters_from_member(member[i])]
        assert got == ref.nc(Dl, bl, 0.99, R), (builder, g, a)
        assert sorted(v for c in got for v in c) == list(range(1, N + 1))
        # Final state: no pair has a positive merge gain (the loop stopped correctly) ...
        for x in range(len(got)):
            for y in range(x + 1, len(got)):
                assert R(got[x] + got[y]) - R(got[x]) - R(got[y]) <= 1e-4
        # ... and with alpha = 0 every merge gain is <= 0 (triangle inequality): all singletons.
        if a == 0:
            assert len(got) == N


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
    cached = nc(builder, D, beta, psi, gidx, alpha)
    plain = nc(builder, D, beta, psi, gidx, alpha, cache=False)
    np.testing.assert_array_equal(cached, plain)
    merged = (cached.sum(2) > 1).any()
    assert merged  # the check is not vacuous: some instance merged clusters
    clusters = [clusters_from_member(m) for m in cached]
    a = plan_tours(builder, D, beta, psi, gidx, alpha, clusters)
    b = plan_tours(builder, D, beta, psi, gidx, alpha, [clusters_from_member(m) for m in plain])
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
        direct = evaluate_clusters(builder, D, beta, psi, gg, aa, masks)
        c, p = evaluate_parts(builder, D, beta, psi, gg.astype(np.int32), masks)
        np.testing.assert_array_equal(combine(c, p, aa), direct)  # the same float64 computation


def test_nc_gi_resume_gives_the_same_clusters_as_rebuilding():
    D, beta, psi = batch([3, 4], rewards="4-6")
    gidx = np.repeat(np.arange(2), len(ALPHAS))
    alpha = np.tile(ALPHAS, 2)
    fast = nc("gi", D, beta, psi, gidx, alpha, resume=True)
    slow = nc("gi", D, beta, psi, gidx, alpha, resume=False)
    assert (fast == slow).all()
    assert any(len(clusters_from_member(m)) < N for m in fast)  # merges happened


def test_plan_tours_drops_unprofitable_robots():
    D, beta, psi = batch([0])
    res = plan_tours("ng", D, beta, psi, np.array([0, 0]), np.array([0.0, 500.0]),
                        [[[v] for v in range(1, N + 1)]] * 2)
    assert len(res[0][1]) == N and res[0][0] > 0
    assert res[1] == (0.0, [])
