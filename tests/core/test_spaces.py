"""jaxdc.core.spaces and the environments' gymnax-style spaces; out-of-range actions; unlimited energy observed."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import grid, spaces
from jaxdc.dcg.env import DCG
from jaxdc.dcp.env import DCP

ENVS = [(DCP(grid_size=5, total_reward=7), dict(energy=(4.0, 9.0), max_steps=40)),
        (DCG(grid_size=4, total_reward=3, history=2), dict(energy=6.0, max_steps=30))]


def test_discrete_and_box_follow_gymnax_semantics():
    d = spaces.Discrete(9)
    assert d.n == 9 and d.shape == () and bool(d.contains(8)) and not bool(d.contains(9))
    assert not bool(d.contains(-1)) and not bool(d.contains(2.5))
    draws = jax.vmap(d.sample)(jax.random.split(jax.random.PRNGKey(0), 500))
    assert set(np.unique(np.asarray(draws))) == set(range(9))
    b = spaces.Box(0.0, np.array([1.0, 2.0]), (2,))
    x = b.sample(jax.random.PRNGKey(1))
    assert x.shape == (2,) and bool(b.contains(x)) and not bool(b.contains(jnp.array([0.5, 2.5])))
    assert not bool(b.contains(jnp.zeros(3)))
    with pytest.raises(ValueError, match="finite"):
        spaces.Box(0.0, np.inf, (2,))
    with pytest.raises(ValueError, match="num_categories"):
        spaces.Discrete(0)


@pytest.mark.parametrize("env,kw", ENVS, ids=["dcp", "dcg"])
@pytest.mark.parametrize("unlimited", [False, True])
def test_every_observation_lies_in_the_finite_observation_space(env, kw, unlimited):
    if unlimited:
        kw = dict(kw, energy=(math.inf, math.inf) if isinstance(env, DCP) else math.inf)
    params = env.make_params(**kw)
    space = env.observation_space(params)
    assert np.all(np.isfinite(space.high)) and space.shape == env.observation_shape(params)
    assert env.action_space(params).n == 9 and env.name == type(env).__name__
    obs, state = env.reset(jax.random.PRNGKey(0), params)

    def body(carry, key):
        obs, state = carry
        k_a, k_s = jax.random.split(key)
        action = jax.random.randint(k_a, (), 0, 9)
        obs, state, reward, *_ , info = env.step(k_s, state, action, params)
        return (obs, state), (obs, info["final_observation"], reward)

    _, (seen, final, rewards) = jax.lax.scan(body, (obs, state), jax.random.split(jax.random.PRNGKey(1), 400))
    for o in (obs, *seen, *final):
        assert bool(space.contains(o))
    assert np.all(np.isfinite(np.asarray(rewards)))


@pytest.mark.parametrize("env,kw", ENVS, ids=["dcp", "dcg"])
def test_unlimited_energy_is_observed_as_the_step_cap(env, kw):
    params = env.make_params(**dict(kw, energy=(math.inf, math.inf) if isinstance(env, DCP) else math.inf))
    obs, state = env.reset(jax.random.PRNGKey(2), params)
    assert math.isinf(float(state.energy))  # the state keeps the budget unlimited
    agent = np.asarray(obs)[..., 1]
    assert agent.max() == kw["max_steps"]


@pytest.mark.parametrize("env,kw", ENVS, ids=["dcp", "dcg"])
@pytest.mark.parametrize("bad,clipped", [(9, 8), (100, 8), (-1, 0), (-2, 0)])
def test_out_of_range_actions_are_clipped_and_flagged(env, kw, bad, clipped):
    params = env.make_params(**kw)
    _, state = env.reset(jax.random.PRNGKey(3), params)
    key = jax.random.PRNGKey(4)
    out_bad = env.step_env(key, state, jnp.int32(bad), params)
    out_ok = env.step_env(key, state, jnp.int32(clipped), params)
    assert bool(out_bad[-1]["invalid_action"]) and not bool(out_ok[-1]["invalid_action"])
    jax.tree_util.tree_map(np.testing.assert_array_equal, out_bad[1], out_ok[1])


def test_clip_action_flags_exactly_the_out_of_range_values():
    a = jnp.arange(-3, 12)
    clipped, invalid = grid.clip_action(a)
    np.testing.assert_array_equal(np.asarray(invalid), (np.arange(-3, 12) < 0) | (np.arange(-3, 12) > 8))
    np.testing.assert_array_equal(np.asarray(clipped), np.clip(np.arange(-3, 12), 0, 8))
