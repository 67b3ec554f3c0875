"""jaxdc.core.tour_criteria against a direct numpy transcription of Eqs. 3.2-3.7."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from jaxdc.core.tour_criteria import APPEND_CRITERIA, append_scores

K = 6


def _ref(criterion, p_next, p_pair, beta, mask, p_end):
    """Loops over the equations with rho(t + u) - rho(t) = p_end p_next[u] beta[u]."""
    cand = [u for u in range(K) if mask[u]]
    ng = {u: p_end * p_next[u] * beta[u] for u in cand}  # Eq. 3.2

    def two(u, v):  # rho(t + u + v) - rho(t)
        return ng[u] + p_end * p_next[u] * p_pair[u, v] * beta[v]

    def delta(u, v):  # Eq. 3.4
        return ng[v] - (two(u, v) - ng[u])

    out = np.full(K, -np.inf)
    for u in cand:
        others = [v for v in cand if v != u]
        if criterion == "ng":
            s = ng[u]
        elif criterion == "osa":  # Eq. 3.3 (just the gain when u is the last candidate)
            s = max(two(u, v) for v in others) if others else ng[u]
        elif criterion == "tl":  # Eq. 3.5, minimised
            s = -sum(delta(u, v) for v in others)
        elif criterion == "gml":  # Eq. 3.6
            s = ng[u] - (min(delta(u, v) for v in others) if others else 0.0)
        else:  # Eq. 3.7, minimised
            s = -sum(delta(u, v) for v in others) / ng[u]
        out[u] = s
    return out


@pytest.mark.parametrize("criterion", APPEND_CRITERIA)
def test_criteria_match_equations(criterion):
    f = jax.jit(lambda a, b, c, d, e: append_scores(criterion, a, b, c, d, e))
    rng = np.random.default_rng(abs(hash(criterion)) % 2**32)
    for trial in range(15):
        p_next = rng.uniform(0.05, 1, K).astype(np.float32)
        p_pair = rng.uniform(0.05, 1, (K, K)).astype(np.float32)
        p_pair = (p_pair + p_pair.T) / 2
        np.fill_diagonal(p_pair, 1.0)
        beta = rng.integers(1, 6, K).astype(np.float32)
        mask = rng.random(K) < 0.7
        if trial == 0:
            mask[:] = True
        if trial == 1:
            mask[:] = False
            mask[2] = True
        if not mask.any():
            mask[0] = True
        p_end = 1.0 if trial % 2 else float(rng.uniform(0.3, 1))
        got = np.asarray(f(p_next, p_pair, beta, mask, np.float32(p_end)))
        want = _ref(criterion, p_next.astype(np.float64), p_pair.astype(np.float64), beta, mask, p_end)
        assert np.all(np.isneginf(got[~mask]))
        np.testing.assert_allclose(got[mask], want[mask], rtol=1e-4, atol=1e-5)
        # the chosen candidate is the best of the transcription
        assert want[int(np.argmax(got))] >= want[mask].max() - 1e-5 * max(1, abs(want[mask].max()))


def test_lpg_init_inf_makes_all_tie():
    rng = np.random.default_rng(0)
    p_next = rng.uniform(0.1, 1, K).astype(np.float32)
    p_pair = rng.uniform(0.1, 1, (K, K)).astype(np.float32)
    beta = rng.integers(1, 5, K).astype(np.float32)
    mask = np.array([False, True, True, True, False, True])
    s = np.asarray(append_scores("lpg", p_next, p_pair, beta, mask, lpg_init=np.inf))
    assert np.all(np.isneginf(s[~mask]))
    assert len(set(s[mask].tolist())) == 1  # every valid candidate ties
    assert int(np.argmax(s)) == 1  # so the first one wins
    s0 = np.asarray(append_scores("lpg", p_next, p_pair, beta, mask))
    assert len(set(s0[mask].tolist())) > 1


def test_unknown_criterion():
    with pytest.raises(ValueError, match="criterion"):
        append_scores("gi", np.ones(2), np.ones((2, 2)), np.ones(2), np.ones(2, bool))
