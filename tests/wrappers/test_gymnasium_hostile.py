"""Hostile input for the gymnasium adapters (jaxdc.wrappers.gymnasium): parameters of another environment,
stepping past the end of an episode, unknown reset options."""

from __future__ import annotations

import pytest

from jaxdc.dcg.env import DCG
from jaxdc.dcp.env import DCP
from jaxdc.wrappers.gymnasium import JaxToGymnasium, JaxVectorEnv


def test_params_of_another_grid_size_refused_at_construction():
    with pytest.raises(ValueError, match=r"params\.risk has shape \(6, 6\), but DCP\(grid_size=8\)"):
        JaxToGymnasium(DCP(grid_size=8), DCP(grid_size=6).make_params())
    with pytest.raises(ValueError, match=r"params\.risk has shape \(6, 6\)"):
        JaxVectorEnv(DCP(grid_size=8), 2, DCP(grid_size=6).make_params())
    with pytest.raises(TypeError, match="EnvParams of DCG"):
        JaxToGymnasium(DCG(grid_size=5), DCP(grid_size=5).make_params())


def _finished_episode(env):
    """A JaxToGymnasium whose episode just ended, and how (step until terminated or truncated)."""
    env.reset(seed=0)
    for _ in range(200):
        _, _, terminated, truncated, _ = env.step(0)
        if terminated or truncated:
            return "terminated" if terminated else "truncated"
    raise AssertionError("the episode did not end")


def test_step_after_the_end_without_reset_refused():
    """Stepping a finished episode kept paying reward; now it raises, and reset() starts a new one."""
    gym = JaxToGymnasium(DCP(grid_size=4), DCP(grid_size=4).make_params(max_steps=5))
    how = _finished_episode(gym)
    with pytest.raises(RuntimeError, match=f"episode has ended \\({how}\\); call reset"):
        gym.step(0)
    gym.reset()
    gym.step(0)  # a new episode steps again


@pytest.mark.parametrize("options", [{"risk": "low"}, {"seed": 3, "x": 1}])
def test_unknown_reset_options_refused(options):
    gym = JaxToGymnasium(DCP(grid_size=4))
    with pytest.raises(ValueError, match="reset options .* not known"):
        gym.reset(seed=0, options=options)
    vec = JaxVectorEnv(DCP(grid_size=4), 2)
    with pytest.raises(ValueError, match=next(iter(options))):
        vec.reset(seed=0, options=options)
    gym.reset(seed=0, options={})  # an empty dict is no option
    with pytest.raises(TypeError, match="options must be a dict"):
        gym.reset(options=["risk"])
