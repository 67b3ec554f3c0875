"""Per-episode DCP instances: maps and budgets drawn at reset (jaxdc.dcp.instances, DCP(observation="general"))."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import grid
from jaxdc.core.rollout import run_episodes
from jaxdc.dcp import instances as I
from jaxdc.dcp.env import DCP, ENERGY_SCALE
from jaxdc.dcp.evaluate import evaluate_heuristic, summarize
from tests.support.draws import assert_power_law


def _maps(n=8):
    safe = np.zeros((n, n), np.float32)
    deadly = np.full((n, n), 0.9, np.float32)
    deadly[0, 0] = 0.0
    return np.stack([safe, deadly])


def test_reset_draws_the_map_and_budget_from_the_params():
    env = DCP(total_reward=10, observation="general")
    params = I.instance_params(env, _maps(), (10, 20), init_fraction=0.5)
    keys = jax.random.split(jax.random.PRNGKey(0), 400)
    obs, states = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
    ids, max_e, e = (np.asarray(x) for x in (states.map_id, states.max_energy, states.energy))
    assert set(ids.tolist()) == {0, 1}
    assert set(max_e.tolist()) == set(range(10, 21))
    np.testing.assert_array_equal(e, np.clip(np.round(0.5 * max_e), 1, max_e))
    # the general observation shows the episode's own map and budget
    np.testing.assert_allclose(np.asarray(obs[..., 2]), I.check_maps(_maps(), 8)[ids])
    np.testing.assert_allclose(np.asarray(obs[:, 3, 3, 3]), max_e / ENERGY_SCALE)
    assert env.observation_space(params).contains(obs[0])


def test_each_episode_is_played_on_its_own_map():
    env = DCP(total_reward=30)
    params = I.instance_params(env, _maps(), (16, 16))
    final = evaluate_heuristic(env, params, "safe_reward", jax.random.PRNGKey(1), 600)
    ids = np.asarray(final.map_id)
    risk_losses = np.asarray(final.outcome) == 1  # "risk"
    assert not risk_losses[ids == 0].any()  # the safe map never disables the agent
    assert risk_losses[ids == 1].mean() > 0.5


def test_fixed_instance_plays_like_the_thesis_setting():
    env = DCP(total_reward=30)
    fixed = I.fixed_instance(env, "high", (8, 16))
    plain = env.make_params("high", (8, 16))
    a = summarize(evaluate_heuristic(env, fixed, "safe_reward", jax.random.PRNGKey(2), 2000))["reward"]
    b = summarize(evaluate_heuristic(env, plain, "safe_reward", jax.random.PRNGKey(3), 2000))["reward"]
    se = np.hypot(a["sd"], b["sd"]) / np.sqrt(2000)
    assert abs(a["mean"] - b["mean"]) < 4 * se


def test_heuristics_read_each_episodes_own_table():
    env = DCP(total_reward=5)
    maps = _maps()
    params = I.instance_params(env, maps, (16, 16))
    # jitted: op by op, the batched reset and heuristics dispatched (and compiled) every primitive alone
    _, states = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(jax.random.split(jax.random.PRNGKey(4), 64), params)
    h = jax.jit(I.batched_heuristics(params))(states)
    risk_row = np.asarray(h[:, 9])  # the risk of each action's target cell
    ids = np.asarray(states.map_id)
    assert np.all(risk_row[ids == 0] == 0) and np.all(risk_row[ids == 1].max(-1) > 0.5)


def test_thesis_observation_is_unchanged_by_the_option():
    env, general = DCP(), DCP(observation="general")
    params = env.make_params()
    obs, state = env.reset(jax.random.PRNGKey(0), params)
    obs_g, state_g = general.reset(jax.random.PRNGKey(0), params)
    assert obs.shape == (8, 8, 2) and obs_g.shape == (8, 8, 4)
    np.testing.assert_array_equal(obs_g[..., 0], obs[..., 0])
    np.testing.assert_allclose(obs_g[..., 1] * ENERGY_SCALE, obs[..., 1])
    np.testing.assert_array_equal(obs_g[..., 2], params.risk)
    assert state.map_id is None and general != env and hash(general) != hash(env)


@pytest.mark.parametrize("maps, energy_range, frac, match", [
    (np.zeros((8, 8)), (8, 16), 0.5, "maps must be an array"),
    (np.full((1, 8, 8), 0.5), (8, 16), 0.5, "base cell"),
    (np.pad(np.ones((1, 8, 7)), ((0, 0), (0, 0), (1, 0))), (8, 16), 0.5, "risk of 1"),
    (np.zeros((1, 6, 6)), (8, 16), 0.5, "6x6 but grid_size is 8"),
    (np.zeros((1, 8, 8)), (16, 8), 0.5, "low .* must not exceed high"),
    (np.zeros((1, 8, 8)), (8.5, 16), 0.5, "whole number"),
    (np.zeros((1, 8, 8)), (1, 16), 0.5, "energy_range low"),
    (np.zeros((1, 8, 8)), (8, float("inf")), 0.5, "energy_range high"),
    (np.zeros((1, 8, 8)), (8, 16), 0.0, "init_fraction"),
    (np.zeros((1, 8, 8)), 8, 0.5, "energy_range must be a pair"),
])
def test_bad_instance_parameters_are_refused_by_name(maps, energy_range, frac, match):
    with pytest.raises((ValueError, TypeError), match=match):
        I.instance_params(DCP(), maps, energy_range, frac)


@pytest.mark.parametrize("tilt", [1.0, 2.5])
def test_a_tilted_budget_draw_follows_its_power_law(tilt):
    """``energy_tilt`` (beyond the thesis): each maximum energy E of the range has the mass of ``x ** -tilt`` over
    [E, E + 1), and the initial energy is still its fraction."""
    env = DCP(total_reward=10, observation="general")
    params = I.instance_params(env, _maps(), (8, 48), init_fraction=0.5, energy_tilt=tilt)
    keys = jax.random.split(jax.random.PRNGKey(5), 20000)
    states = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)[1]
    drawn, e = np.asarray(states.max_energy), np.asarray(states.energy)
    assert_power_law(drawn, 8, 48, tilt)
    np.testing.assert_array_equal(e, np.clip(np.round(0.5 * drawn), 1, drawn))


def test_a_zero_tilt_gives_the_same_params_and_episodes():
    env = DCP(total_reward=10, observation="general")
    uniform = I.instance_params(env, _maps(), (8, 48))
    zero = I.instance_params(env, _maps(), (8, 48), energy_tilt=0.0)
    assert zero.energy_tilt is None
    chex.assert_trees_all_equal(uniform, zero)
    tilted = I.instance_params(env, _maps(), (8, 48), energy_tilt=1.0)
    key = jax.random.PRNGKey(0)
    a, b = env.reset(key, uniform)[1], env.reset(key, tilted)[1]
    np.testing.assert_array_equal(np.asarray(a.items), np.asarray(b.items))  # the tilt moves the budget only
    assert a.map_id == b.map_id


@pytest.mark.parametrize("tilt, error, match", [
    (float("nan"), ValueError, "energy_tilt must be >= -8 and <= 8, got NaN"),
    (9.0, ValueError, "energy_tilt must be >= -8 and <= 8, got 9"),
    ("1", TypeError, "energy_tilt must be a number"),
])
def test_bad_energy_tilts_are_refused_by_name(tilt, error, match):
    with pytest.raises(error, match=match):
        I.instance_params(DCP(), _maps(), (8, 16), energy_tilt=tilt)


def test_observation_option_is_validated():
    with pytest.raises(ValueError, match="observation must be one of"):
        DCP(observation="pixels")


def test_instances_run_in_the_batched_rollout_with_auto_reset():
    env = DCP(total_reward=10, observation="general")
    params = I.instance_params(env, np.stack([grid.risk_map(p, 8) for p in ("low", "high")]), (8, 32))
    final = jax.jit(lambda k: run_episodes(env, params, I.heuristic_policy("safe_both", params), k, 256))(
        jax.random.PRNGKey(5))
    assert np.all(np.asarray(final.outcome) > 0)
    assert set(np.asarray(final.map_id).tolist()) == {0, 1}
    assert jnp.all(final.max_energy >= 8) and jnp.all(final.max_energy <= 32)


@pytest.mark.parametrize("energy, match", [((20, 10), "must not exceed the maximum"),
                                           ((8, float("inf")), "finite maximum energy"),
                                           ((float("nan"), 16), "initial energy")])
def test_fixed_instance_names_a_bad_budget(energy, match):
    with pytest.raises((ValueError, TypeError), match=match):
        I.fixed_instance(DCP(), "high", energy)
