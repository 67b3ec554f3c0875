"""The check of a tilted integer draw (:func:`jaxdc.core.sampling.power_law_integer`: the maximum energy of
:func:`jaxdc.core.energy.draw_max_energy` and the DCP's item count), shared by the DCP's and the DCG's tests."""

from __future__ import annotations

import numpy as np


def power_law_masses(low: int, high: int, tilt: float) -> np.ndarray:
    """The probability of each integer ``E`` in ``[low, high]``: the mass of ``x ** -tilt`` over ``[E, E + 1)``,
    normalised."""
    edges = np.arange(float(low), high + 2.0)
    mass = np.diff(np.log(edges) if tilt == 1.0 else edges ** (1.0 - tilt) / (1.0 - tilt))
    return mass / mass.sum()


def assert_power_law(drawn: np.ndarray, low: int, high: int, tilt: float) -> np.ndarray:
    """Assert that the share of each integer drawn is within 5 standard errors of :func:`power_law_masses`; return
    the expected shares."""
    expected = power_law_masses(low, high, tilt)
    observed = np.bincount(drawn.astype(int), minlength=high + 1)[low:] / drawn.size
    se = np.sqrt(expected * (1 - expected) / drawn.size)
    assert np.all(np.abs(observed - expected) < 5 * se), (observed, expected)
    return expected
