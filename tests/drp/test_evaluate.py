"""Cluster rewards in bulk: the batching scheduler and the host-side rewards of the device-built tours."""

import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.drp import world
from jaxdc.drp.batching import bucket, bucketed, width
from jaxdc.drp.evaluate import ClusterEvaluation, evaluate, evaluate_clusters
from tests.support.drp_reference import graph_batch

N = 7
ALPHAS = [0.0, 10.0, 25.0, 40.0]


def batch(seeds, rewards="1-9"):
    return graph_batch(seeds, N, rewards)


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
        together = evaluate_clusters(builder, D, beta, psi, gidx, alpha, masks)
        for j in (0, 17, 299):
            alone = evaluate_clusters(builder, D, beta, psi, gidx[j:j + 1], alpha[j:j + 1], masks[j:j + 1])
            assert alone[0] == together[j]
        assert together.dtype == np.float64
        # ... and they are Eq. 3.1 of the tour (float32 jax computation, to float32 precision).
        rewards, tours = evaluate_clusters(builder, D, beta, psi, gidx, alpha, masks, with_tours=True)
        for j in (0, 17, 299):
            b = beta[gidx[j]].at[0].set(alpha[j])
            want = float(world.tour_reward(D[gidx[j]], b, psi[gidx[j]], jnp.asarray(tours[j])))
            assert rewards[j] == pytest.approx(want, rel=1e-5, abs=1e-4)


def test_buckets_and_widths():
    assert [bucket(s, 100) for s in (1, 2, 3, 5, 17, 24, 25, 33, 48, 49, 89, 90, 100)] == \
        [2, 2, 4, 8, 24, 24, 32, 48, 48, 64, 100, 100, 100]
    assert bucket(7, 7) == 7 and bucket(3, 10) == 4
    assert width(9) == 4096 and width(101 ** 2) == 32 and width(10 ** 9) == 16


def test_bucketed_covers_every_job_once_in_padded_chunks():
    sizes = np.array([1, 5, 3, 30, 2, 5, 40, 8])
    calls = []
    bucketed(sizes, 40, lambda K, part, pad: calls.append((K, part.copy(), pad.copy())), area=lambda K: 2 ** 16)
    assert sorted(j for _, part, _ in calls for j in part) == list(range(len(sizes)))
    for K, part, pad in calls:
        assert all(bucket(sizes[j], 40) == K for j in part)
        assert len(pad) == width(2 ** 16) and (pad[:len(part)] == part).all() and (pad[len(part):] == part[0]).all()
        assert list(sizes[part]) == sorted(sizes[part])  # jobs of similar size share a while_loop


def test_evaluate_names_its_parts():
    D, beta, psi = batch([6])
    masks = np.zeros((3, N + 1), bool)
    masks[0, 1:4] = masks[1, 2] = True
    res = evaluate("tl", D, beta, psi, np.zeros(3, np.int32), np.array([0.0, 10.0, 5.0], np.float32), masks)
    assert isinstance(res, ClusterEvaluation)
    np.testing.assert_array_equal(res.rewards, (res.collected + res.p_return * np.array([0.0, 10.0, 5.0])) -
                                  np.array([0.0, 10.0, 5.0]))
    assert res.collected[2] == res.p_return[2] == 0 and (res.tours[2] == -1).all()  # an empty cluster: no tour
    assert sorted(res.tours[0][res.tours[0] >= 0]) == [1, 2, 3] and list(res.tours[1][:2]) == [2, -1]
