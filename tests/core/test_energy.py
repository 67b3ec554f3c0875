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


@pytest.mark.parametrize("value,error,message", [
    (1e40, ValueError, "<= 16777216"), (2.0**24 + 1, ValueError, "<= 16777216"), (float("nan"), ValueError, "NaN"),
    (0.0, ValueError, "> 0"), (-float("inf"), ValueError, "> 0"), (True, TypeError, "a number"),
])
def test_budgets_that_float32_cannot_count_are_refused(value, error, message):
    with pytest.raises(error, match=message):
        energy.check_budget("energy", value)
    with pytest.raises(error, match=message):
        dcg_env.DCG().make_params(energy=value)
    with pytest.raises(error, match=message):
        dcp_env.DCP().make_params(energy=(value, value) if value == value and value > 0 else (value, 16.0))


def test_observed_energy_is_finite():
    assert float(energy.observed_energy(jnp.float32(float("inf")), jnp.int32(70))) == 70.0
    assert float(energy.observed_energy(jnp.float32(3.0), jnp.int32(70))) == 3.0
    assert energy.observed_energy_bound(float("inf"), 70) == 70.0 and energy.observed_energy_bound(9.0, 70) == 9.0
    assert energy.observed_energy_bound(float("inf"), 5, init_energy=9.0) == 9.0
    assert energy.observed_energy_bound(float("inf"), 50, init_energy=9.0) == 50.0
