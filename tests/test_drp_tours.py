"""The six builders against the plain-Python transcription of Eqs. 3.2-3.8."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import drp_reference as ref
from jaxdc.drp import tours, world

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
