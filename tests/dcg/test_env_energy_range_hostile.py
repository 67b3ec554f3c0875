"""Bad per-episode budgets and observations of the DCG are refused at construction, naming the parameter and the
value (beyond the thesis, docs/generalisation.md)."""

from __future__ import annotations

import pytest

from jaxdc.core.energy import check_energy_range
from jaxdc.dcg.env import DCG
from jaxdc.dcp.instances import check_energy_range as dcp_check
from jaxdc.nets.registry import build
from jaxdc.training.dcg import DCGSettings

BAD_RANGES = [
    ((25, 8), ValueError, r"energy_range: low \(25\) must not exceed high \(8\)"),
    ((8.5, 25), ValueError, "energy_range low must be a whole number, got 8.5"),
    ((8, 24.5), ValueError, "energy_range high must be a whole number, got 24.5"),
    ((0, 8), ValueError, "energy_range low"),
    ((-3, 8), ValueError, "energy_range low"),
    ((0.5, 8), ValueError, "energy_range low"),
    ((float("nan"), 8), ValueError, "energy_range low"),
    ((8, float("inf")), ValueError, "energy_range high"),
    ((8, 2.0**25), ValueError, "energy_range high"),
    ((8,), TypeError, "energy_range must be a pair"),
    ((8, 9, 10), TypeError, "energy_range must be a pair"),
    (8, TypeError, "energy_range must be a pair"),
    (("8", "25"), TypeError, "energy_range low"),
    ((True, 8), TypeError, "energy_range low"),
]


@pytest.mark.parametrize("energy_range, error, match", BAD_RANGES)
def test_bad_energy_ranges_are_refused_by_make_params(energy_range, error, match):
    with pytest.raises(error, match=match):
        DCG().make_params(energy_range=energy_range)


@pytest.mark.parametrize("energy_range, error, match", BAD_RANGES[:3])
def test_bad_energy_ranges_are_refused_by_the_training_settings(energy_range, error, match):
    from jaxdc.agents.a2c import A2CConfig

    with pytest.raises(error, match=match):
        DCGSettings(net="vnn", config=A2CConfig(), energy_range=energy_range)


@pytest.mark.parametrize("tilt, error, match", [
    (float("nan"), ValueError, "energy_tilt must be >= -8 and <= 8, got NaN"),
    (9.0, ValueError, "energy_tilt must be >= -8 and <= 8, got 9"),
    (-8.5, ValueError, "energy_tilt must be >= -8 and <= 8, got -8.5"),
    (float("inf"), ValueError, "energy_tilt"),
    ("1", TypeError, "energy_tilt must be a number"),
    (None, TypeError, "energy_tilt must be a number"),
])
def test_bad_energy_tilts_are_refused_by_make_params(tilt, error, match):
    with pytest.raises(error, match=match):
        DCG().make_params(energy_range=(8, 25), energy_tilt=tilt)


def test_a_tilt_needs_a_range():
    from jaxdc.agents.a2c import A2CConfig

    with pytest.raises(ValueError, match="energy_tilt tilts the draw of energy_range and needs one, got energy_tilt=1"):
        DCG().make_params(energy_tilt=1.0)
    with pytest.raises(ValueError, match="energy_tilt=2 tilts the draw of energy_range"):
        DCGSettings(net="vnn", config=A2CConfig(), energy_tilt=2.0)
    with pytest.raises(ValueError, match="energy_tilt must be >= -8"):
        DCGSettings(net="vnn", config=A2CConfig(), energy_range=(8, 25), energy_tilt=10.0)


def test_the_smallest_budget_is_one_for_the_dcg_and_two_for_the_dcp():
    assert DCG().make_params(energy_range=(1, 1)).energy_range.tolist() == [1.0, 1.0]
    assert check_energy_range((1, 3), 1.0) == (1.0, 3.0)
    with pytest.raises(ValueError, match="energy_range low"):
        dcp_check((1, 3))


def test_bad_observations_are_refused():
    with pytest.raises(ValueError, match=r"observation must be one of \('thesis', 'general'\), got 'budget'"):
        DCG(observation="budget")
    from jaxdc.agents.a2c import A2CConfig

    with pytest.raises(ValueError, match="observation must be one of"):
        DCGSettings(net="vnn", config=A2CConfig(), observation="General")
    with pytest.raises(ValueError, match="state_channels must be 2 .* or 3 .*, got 4"):
        build("dcg", "imnn", state_channels=4)


def test_a_network_refuses_observations_of_the_other_kind():
    import jax
    import jax.numpy as jnp

    net = build("dcg", "imnn", history=2, state_channels=3)
    with pytest.raises(ValueError, match=r"expects observations \[B, N, N, 5\]"):
        net.init(jax.random.PRNGKey(0), jnp.zeros((1, 3, 3, 4)))
