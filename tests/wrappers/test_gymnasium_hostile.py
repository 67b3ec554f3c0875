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


# ----------------------------------------------------------------------------- refused resets change nothing


def _snapshot(env):
    import jax
    import numpy as np

    key = None if env._key is None else np.asarray(env._key).tolist()
    state = None if env.state is None else [np.asarray(x).tolist() for x in jax.tree_util.tree_leaves(env.state)]
    return key, state, env._ended, env._np_random.bit_generator.state if env._np_random is not None else None


@pytest.mark.parametrize("bad", [{"seed": 0, "options": {"risk": "low"}}, {"seed": -1}, {"seed": 2**32},
                                 {"options": ["risk"]}])
@pytest.mark.parametrize("first", [True, False])
def test_a_refused_reset_changes_nothing(bad, first):
    """jaxdc's reset checks its seed and options before it touches anything: a refused reset (the first one or a
    later one) leaves the key, the state, the episode's end and gymnasium's np_random as they were."""
    for env in (JaxToGymnasium(DCP(grid_size=4)), JaxVectorEnv(DCP(grid_size=4), 2)):
        if not first:
            env.reset(seed=3)
            env.step(0 if isinstance(env, JaxToGymnasium) else [0, 0])
        before = _snapshot(env)
        with pytest.raises((TypeError, ValueError), match="seed|options"):
            env.reset(**bad)
        assert _snapshot(env) == before
        env.reset(seed=0)
        env.step(0 if isinstance(env, JaxToGymnasium) else [0, 0])


@pytest.mark.parametrize("env_id, bad", [("jaxdc/DCP-v0", {"seed": 0, "options": {"risk": "low"}}),
                                         ("jaxdc/DCP-v0", {"seed": -1}), ("jaxdc/DCG-v0", {"seed": -1})])
def test_gym_make_steps_after_a_refused_first_reset(env_id, bad):
    """Through gym.make: a refused first reset, then reset(seed=0) and step(0) must work (gymnasium's passive
    checker raised ``TypeError: cannot unpack non-iterable NoneType object`` on that step)."""
    import gymnasium

    kwargs = {"grid_size": 4} if "DCP" in env_id else {}
    env = gymnasium.make(env_id, **kwargs)
    with pytest.raises((TypeError, ValueError), match="seed|options"):
        env.reset(**bad)
    env.reset(seed=0)
    assert len(env.step(0)) == 5


@pytest.mark.parametrize("make", [lambda: JaxVectorEnv(DCP(grid_size=4), num_envs=10**9),
                                  lambda: __import__("gymnasium").make_vec("jaxdc/DCP-v0", num_envs=10**9,
                                                                           grid_size=4)])
def test_a_vector_too_large_for_memory_is_refused_before_allocating(make, monkeypatch):
    """10**9 copies: refused by jaxdc's memory check naming num_envs, before the batched spaces' bounds are allocated
    (numpy's MemoryError for 477 GiB before)."""
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(64 * 2**20))
    with pytest.raises(MemoryError, match="num_envs"):
        make()
