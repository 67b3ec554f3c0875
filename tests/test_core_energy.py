"""jaxdc.core.energy: the refill/decrement rule and the energy metrics, shared by the DCP and the DCG."""

from __future__ import annotations

import jax.numpy as jnp
import pytest

from jaxdc.core import energy
from jaxdc.dcg import env as dcg_env
from jaxdc.dcp import env as dcp_env


def test_both_problems_use_the_one_rule():
    assert dcp_env.ENERGY_METRICS is energy.ENERGY_METRICS is dcg_env.ENERGY_METRICS


@pytest.mark.parametrize("e, in_base, expected", [
    (5.0, False, (4.0, False)), (1.0, False, (0.0, True)), (0.0, False, (0.0, True)),
    (1.0, True, (8.0, False)), (float("inf"), False, (float("inf"), False)),
])
def test_step_energy(e, in_base, expected):
    new, out = energy.step_energy(jnp.float32(e), jnp.float32(8.0), jnp.bool_(in_base))
    assert (float(new), bool(out)) == expected


@pytest.mark.parametrize("metric, expected", [
    # (in_base, was_in_base) = (T, T), (T, F), (F, T), (F, F)
    ("not_stay_in_base", (False, True, True, True)),
    ("outside_base", (False, False, True, True)),
    ("all_steps", (True, True, True, True)),
])
def test_energy_used(metric, expected):
    cases = ((True, True), (True, False), (False, True), (False, False))
    got = tuple(bool(energy.energy_used(metric, jnp.bool_(a), jnp.bool_(b))) for a, b in cases)
    assert got == expected


def test_unknown_metric():
    with pytest.raises(ValueError, match="energy_metric must be one of"):
        energy.energy_used("most_steps", jnp.bool_(True), jnp.bool_(True))
