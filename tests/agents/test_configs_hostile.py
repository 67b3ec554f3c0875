"""Hostile values for the agents' configs (A2CConfig, QConfig): non-finite and huge values are refused
naming the field.
"""

from __future__ import annotations

import pytest

from jaxdc.agents.a2c import A2CConfig
from jaxdc.agents.nstep_q import QConfig

# ----------------------------------------------------------------------------- configs (API)

@pytest.mark.parametrize("cls, kwargs, name", [
    (A2CConfig, {"lr": float("inf")}, "lr"),
    (A2CConfig, {"entropy_coef": float("nan")}, "entropy_coef"),
    (A2CConfig, {"aux_lr": float("inf")}, "aux_lr"),
    (A2CConfig, {"gamma": float("nan")}, "gamma"),
    (A2CConfig, {"num_envs": 2**40}, "num_envs"),
    (QConfig, {"eps_end": float("nan")}, "eps_end"),
    (QConfig, {"target_every": 2**40}, "target_every"),
])
def test_configs_refuse_non_finite_and_huge_values(cls, kwargs, name):
    with pytest.raises((ValueError, TypeError), match=name):
        cls(**kwargs)
