"""Hostile input for the environment base (jaxdc.core.env): parameters and states of another environment (another
grid size, another history length) are refused with the field and both shapes -- eagerly, under jit (when
traced) and at every entry point that steps an environment without Environment.step."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import pytest

from jaxdc.core.rollout import run_episodes
from jaxdc.core.trajectory import play_episode
from jaxdc.dcg.env import DCG
from jaxdc.dcp.env import DCP
from jaxdc.wrappers import batched

KEY = jax.random.PRNGKey(0)


def _first(key, obs, state):
    return jnp.int32(0)


@pytest.mark.parametrize("jit", [False, True])
def test_dcp_params_of_another_grid_size_refused(jit):
    env, other = DCP(grid_size=8), DCP(grid_size=6)
    _, state = env.reset(KEY)
    step = jax.jit(env.step) if jit else env.step
    with pytest.raises(ValueError, match=r"params\.risk has shape \(6, 6\), but DCP\(grid_size=8\) needs \(8, 8\)"):
        step(KEY, state, 0, other.make_params())
    reset = jax.jit(env.reset) if jit else env.reset
    with pytest.raises(ValueError, match=r"params\.risk has shape \(6, 6\)"):
        reset(KEY, other.make_params())


def test_dcp_state_of_another_grid_size_refused():
    _, state = DCP(grid_size=8).reset(KEY)
    with pytest.raises(ValueError, match=r"state\.items has shape \(8, 8\), but DCP\(grid_size=6\) needs \(6, 6\)"):
        DCP(grid_size=6).step(KEY, state, 0)


def test_dcg_state_of_another_grid_or_history_refused():
    _, state = DCG(grid_size=4).reset(KEY)
    with pytest.raises(ValueError, match=r"state\.items has shape \(4, 4\), but DCG\(grid_size=5\)"):
        DCG(grid_size=5).step(KEY, state, 0)
    _, state = DCG(grid_size=5, history=3).reset(KEY)
    with pytest.raises(ValueError, match=r"state\.history has shape \(5, 5, 3\).*\(5, 5, 10\)"):
        jax.jit(DCG(grid_size=5).step)(KEY, state, 0)


def test_params_of_another_environment_refused():
    with pytest.raises(TypeError, match="params must be the EnvParams of DCP.make_params"):
        DCP(grid_size=5).check_params(DCG(grid_size=5).make_params())


def test_batched_params_and_states_of_the_right_grid_pass():
    env = DCP(grid_size=5)
    params = jax.vmap(lambda e: env.make_params(energy=(8.0, 16.0)).replace(max_energy=e))(jnp.array([16.0, 20.0]))
    _, states = jax.vmap(env.reset)(jax.random.split(KEY, 2), params)
    out = jax.vmap(env.step)(jax.random.split(KEY, 2), states, jnp.zeros(2, jnp.int32), params)
    assert out[1].items.shape == (2, 5, 5)


def test_entry_points_that_call_step_env_refuse_other_params():
    env, params = DCP(grid_size=5), DCP(grid_size=4).make_params()
    with pytest.raises(ValueError, match=r"params\.risk has shape \(4, 4\)"):
        run_episodes(env, params, _first, KEY, 2)
    with pytest.raises(ValueError, match=r"params\.risk has shape \(4, 4\)"):
        play_episode(env, params, _first, KEY, 3)
    with pytest.raises(ValueError, match=r"params\.risk has shape \(4, 4\)"):
        batched.reset_one(env, KEY, params)
    with pytest.raises(ValueError, match=r"params\.risk has shape \(4, 4\)"):
        batched.reset(env, 2, KEY, params)
    _, _, state = batched.reset_one(DCP(grid_size=4), KEY, params)
    with pytest.raises(ValueError, match=r"state\.items has shape \(4, 4\)"):
        batched.step_one(env, KEY, state, jnp.int32(0), env.make_params())
