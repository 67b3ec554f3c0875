"""The exact solver against brute force, and against the heuristics."""

import numpy as np
import pytest

from jaxdc.drp import world
from jaxdc.drp.exact import subset_dp
from tests.support import drp_reference as ref


@pytest.mark.parametrize("n", [1, 3, 5, 6])
def test_exact_matches_brute_force(n):
    for seed in range(3):
        g = world.generate(seed, n=n, size=30, rewards="1-9", alpha=float(7 * seed))
        D, beta, _ = world.arrays(g)
        Dl, bl = np.asarray(D, float).tolist(), np.asarray(beta, float).tolist()
        value, tours = subset_dp.solve(Dl, bl, 0.99)
        assert value == pytest.approx(ref.brute_force(Dl, bl, 0.99), rel=1e-9, abs=1e-9)
        assert value == pytest.approx(ref.expected_reward(Dl, bl, 0.99, tours), rel=1e-9, abs=1e-9)
        visited = [v for t in tours for v in t]
        assert len(visited) == len(set(visited))


def test_exact_bounds_the_heuristics():
    for seed in range(3):
        g = world.generate(seed, n=7, size=40, alpha=20.0)
        D, beta, _ = world.arrays(g)
        Dl, bl = np.asarray(D, float).tolist(), np.asarray(beta, float).tolist()
        value, _ = subset_dp.solve(Dl, bl, 0.99)
        for b in ("ng", "gi"):
            def R(C, Dl=Dl, bl=bl, b=b):  # this iteration's instance and builder
                return ref.tour_reward(Dl, bl, 0.99, ref.build_tour(b, Dl, bl, 0.99, C))

            h = sum(max(R(C), 0.0) for C in ref.nc(Dl, bl, 0.99, R))
            assert h <= value + 1e-9


def test_exact_rejects_large_graphs():
    g = world.generate(0, n=10)
    D, beta, _ = world.arrays(g)
    with pytest.raises(ValueError, match="n=10"):
        subset_dp.solve(D, beta, 0.99)
