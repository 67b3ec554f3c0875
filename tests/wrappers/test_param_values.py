"""Parameters edited with ``.replace(...)`` bypass ``make_params``' checks: every non-jitted entry point that takes
params checks their VALUES once (issue 31): the gymnasium and JaxMARL adapters, the DCG evaluators
(:func:`jaxdc.dcg.param_values.check_param_values`; the SB3 adapter in test_sb3_hostile.py, the DCP evaluators in
tests/dcp/test_evaluate_hostile.py). A refusal names ``params.<field>``, the value and the allowed range."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.dcg.env import DCG
from jaxdc.dcg.evaluate import evaluate_network, evaluate_policy
from jaxdc.dcg.param_values import check_param_values
from jaxdc.dcp.env import DCP
from jaxdc.wrappers.gymnasium import JaxToGymnasium, JaxVectorEnv

DCP4 = DCP(grid_size=4)
PB = DCP4.make_params(risk="high")
BAD_DCP = [
    (PB.replace(risk=jnp.full((4, 4), jnp.nan)), r"params\.risk: .*finite numbers in \[0, 1\], got nan"),
    (PB.replace(risk=PB.risk.at[2, 1].set(jnp.inf)), r"params\.risk: .*got inf at cell \(2, 1\)"),
    (PB.replace(risk=PB.risk.at[2, 1].set(-0.5)), r"params\.risk: .*must lie in \[0, 1\]"),
    (PB.replace(risk=PB.risk.at[0, 0].set(0.2)), r"params\.risk: the base cell \(0, 0\) must have risk 0"),
    (PB.replace(max_energy=jnp.float32(-1)), r"params\.init_energy/max_energy: maximum energy must be > 0"),
    (PB.replace(init_energy=jnp.float32(jnp.nan)), r"initial energy must be .*got NaN"),
    (PB.replace(init_energy=jnp.float32(20)), r"initial energy \(20\) must not exceed the maximum energy \(16\)"),
    (PB.replace(max_steps=jnp.int32(0)), r"params\.max_steps: max_steps must be in \[1, 2147483647\], got 0"),
]


@pytest.mark.parametrize("bad, match", BAD_DCP)
def test_the_gymnasium_adapters_refuse_bad_dcp_values(bad, match):
    with pytest.raises(ValueError, match=match):
        JaxToGymnasium(DCP4, params=bad)
    with pytest.raises(ValueError, match=match):
        JaxVectorEnv(DCP4, 2, params=bad)


def test_good_params_pass_and_traced_ones_are_not_checked():
    from jaxdc.dcp import instances
    from jaxdc.dcp.param_values import check_param_values as check_dcp

    JaxToGymnasium(DCP4, params=PB.replace(init_energy=jnp.float32(jnp.inf), max_energy=jnp.float32(jnp.inf)))
    maps = np.stack([np.asarray(PB.risk)] * 2)
    JaxToGymnasium(DCP4, params=instances.instance_params(DCP4, maps, (4, 8), energy_tilt=1.0))
    # inside jit the values are unknown: the check passes traced params through
    jax.jit(check_dcp)(PB.replace(risk=jnp.full((4, 4), jnp.nan)))
    jax.jit(check_param_values)(DCG().make_params().replace(max_steps=jnp.int32(0)))


def test_per_episode_instances_are_checked_too():
    from jaxdc.dcp import instances

    ip = instances.instance_params(DCP4, np.stack([np.asarray(PB.risk)] * 2), (4, 8))
    with pytest.raises(ValueError, match=r"params\.maps: maps\[1\]: risk map values must be finite"):
        JaxToGymnasium(DCP4, params=ip.replace(maps=ip.maps.at[1, 2, 2].set(jnp.nan)))
    with pytest.raises(ValueError, match=r"params\.energy_range: energy_range: low \(8\) must not exceed high"):
        JaxToGymnasium(DCP4, params=ip.replace(energy_range=jnp.asarray([8.0, 4.0])))
    with pytest.raises(ValueError, match=r"params\.init_fraction: init_fraction must be > 0"):
        JaxToGymnasium(DCP4, params=ip.replace(init_fraction=jnp.float32(0)))


G = DCG(grid_size=5)
GP = G.make_params()
BAD_DCG = [
    (GP.replace(max_energy=jnp.float32(jnp.nan)), r"params\.max_energy: max_energy must be .*got NaN"),
    (GP.replace(max_energy=jnp.float32(0)), r"params\.max_energy: max_energy must be > 0"),
    (GP.replace(max_steps=jnp.int32(-3)), r"params\.max_steps: max_steps must be in \[1, 2147483647\], got -3"),
    (GP.replace(chase_tie=jnp.int32(7)), r"params\.chase_tie: .*must be in \[0, 2\], got 7"),
    (G.make_params(energy_range=(4, 8)).replace(energy_range=jnp.asarray([0.0, 8.0])),
     r"params\.energy_range: energy_range low must be >= 1"),
]


@pytest.mark.parametrize("bad, match", BAD_DCG)
def test_dcg_entry_points_refuse_bad_values(bad, match):
    with pytest.raises(ValueError, match=match):
        JaxToGymnasium(G, params=bad)
    with pytest.raises(ValueError, match=match):
        evaluate_policy(G, bad, lambda k, o, s: jnp.int32(0), jax.random.PRNGKey(0), 2)
    with pytest.raises(ValueError, match=match):
        evaluate_network(G, bad, None, None, jax.random.PRNGKey(0), 2)


def test_the_jaxmarl_adapter_refuses_bad_values():
    from jaxdc.dcg.team.env import DCGTeam
    from jaxdc.wrappers.jaxmarl import JaxMARLTeam

    team = DCGTeam(grid_size=5)
    with pytest.raises(ValueError, match=r"params\.max_energy: max_energy must be > 0"):
        JaxMARLTeam(team, team.default_params.replace(max_energy=jnp.float32(-2)))
