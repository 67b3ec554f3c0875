"""Per-episode maximum energies of the DCG (beyond the thesis, docs/generalisation.md): drawn at reset from
``energy_range`` inside jit, kept in the state, refilled to in the base, shown by the general observation; the
faithful default unchanged."""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core.energy import ENERGY_SCALE
from jaxdc.core.env import step_batch
from jaxdc.dcg.env import DCG, EnvState
from jaxdc.nets.registry import build
from tests.support.draws import assert_power_law

KEYS = jax.random.split(jax.random.PRNGKey(3), 2000)


def _reset_many(env, params, keys=KEYS):
    return jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)


def test_draws_every_integer_of_the_range_and_starts_full():
    env = DCG()
    _, state = _reset_many(env, env.make_params(energy_range=(8, 25)))
    drawn = np.asarray(state.max_energy)
    assert set(np.unique(drawn)) == set(np.arange(8.0, 26.0))  # every integer, nothing outside
    counts = np.bincount(drawn.astype(int))[8:]
    assert counts.min() > 2000 / 18 * 0.6 and counts.max() < 2000 / 18 * 1.4  # about uniform (111 each)
    np.testing.assert_array_equal(np.asarray(state.energy), drawn)  # the collector starts with full energy


@pytest.mark.parametrize("tilt", [1.0, 2.0, -1.5])
def test_a_tilted_draw_follows_its_power_law(tilt):
    """``energy_tilt``: each integer E of the range has the mass of ``x ** -tilt`` over [E, E + 1)."""
    env = DCG()
    keys = jax.random.split(jax.random.PRNGKey(7), 20000)
    drawn = np.asarray(_reset_many(env, env.make_params(energy_range=(8, 25), energy_tilt=tilt), keys)[1].max_energy)
    expected = assert_power_law(drawn, 8, 25, tilt)
    assert (expected[0] > expected[-1]) == (tilt > 0)  # a positive tilt weights the low budgets


def test_a_zero_tilt_is_the_uniform_draw():
    env = DCG()
    uniform = env.make_params(energy_range=(8, 25))
    zero = env.make_params(energy_range=(8, 25), energy_tilt=0.0)
    assert zero.energy_tilt is None  # the same params, so the same games
    chex.assert_trees_all_equal(uniform, zero)


def test_draw_is_deterministic_by_key_and_vmaps_over_ranges():
    env = DCG()
    params = env.make_params(energy_range=(8, 25))
    a = _reset_many(env, params)[1].max_energy
    b = _reset_many(env, params)[1].max_energy
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    # a batch of params, each with its own range
    ranges = [(3, 3), (8, 9), (20, 25)]
    batch = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *[env.make_params(energy_range=r) for r in ranges])
    keys = jax.random.split(jax.random.PRNGKey(0), 3 * 200).reshape(3, 200, 2)
    _, st = jax.vmap(lambda k, p: jax.vmap(env.reset, in_axes=(0, None))(k, p))(keys, batch)
    for i, (low, high) in enumerate(ranges):
        e = np.asarray(st.max_energy[i])
        assert e.min() == low and e.max() == high


def test_a_one_value_range_plays_the_fixed_energy_games():
    """The budget draws from its own key: with the range (E, E) items, opponent and strategy are those of the fixed
    energy E, step by step."""
    env = DCG()
    fixed, ranged = env.make_params(energy=12.0), env.make_params(energy_range=(12, 12))
    keys = KEYS[:64]
    obs_f, st_f = _reset_many(env, fixed, keys)
    obs_r, st_r = _reset_many(env, ranged, keys)
    np.testing.assert_array_equal(np.asarray(obs_f), np.asarray(obs_r))
    step = jax.jit(lambda k, s, a, p: step_batch(env, k, s, a, p))
    for t in range(12):
        k = jax.random.PRNGKey(t)
        actions = jax.random.randint(jax.random.PRNGKey(100 + t), (64,), 0, 9)
        obs_f, st_f, r_f, *_ = step(k, st_f, actions, fixed)
        obs_r, st_r, r_r, *_ = step(k, st_r, actions, ranged)
        np.testing.assert_array_equal(np.asarray(obs_f), np.asarray(obs_r))
        np.testing.assert_array_equal(np.asarray(r_f), np.asarray(r_r))


def test_recharge_in_the_base_goes_to_the_episode_maximum():
    env = DCG(strategies="patrol")
    params = env.make_params(energy_range=(8, 25))  # params.max_energy holds the high end, 25
    _, st = _reset_many(env, params)
    i = int(np.flatnonzero(np.asarray(st.max_energy) == 9.0)[0])
    state = jax.tree_util.tree_map(lambda x: x[i], st)
    far = jnp.array([4, 4], jnp.int32)  # the opponent patrols the far corner: no capture near the base
    state = state.replace(pos=jnp.array([0, 1], jnp.int32), energy=jnp.float32(3.0),
                          opponent=state.opponent.replace(pos=far, home=far, target=far))
    key = jax.random.PRNGKey(0)
    _, home, *_ = env.step_env(key, state, 3, params)  # left, into the base
    assert int(home.outcome) == 0 and home.pos.tolist() == [0, 0]
    assert float(home.energy) == 9.0 and float(home.max_energy) == 9.0  # the episode's 9, not the range's 25
    _, out, *_ = env.step_env(key, home, 4, params)  # right, out again
    assert float(out.energy) == 8.0
    low = state.replace(energy=jnp.float32(1.0), pos=jnp.array([1, 1], jnp.int32))
    _, spent, *_ = env.step_env(key, low, 0, params)
    assert float(spent.energy) == 0.0 and int(spent.outcome) == 2  # "energy": disabled at 0


def test_general_observation_shows_the_budget_and_scaled_energies():
    thesis, general = DCG(history=3), DCG(history=3, observation="general")
    assert general.observation_shape() == (5, 5, 6) and thesis.observation_shape() == (5, 5, 5)
    assert general.state_channels == 3 and thesis.state_channels == 2
    params = general.make_params(energy_range=(8, 25))
    obs, st = _reset_many(general, params, KEYS[:200])
    obs_t, st_t = _reset_many(thesis, params, KEYS[:200])
    budget = np.asarray(st.max_energy)
    np.testing.assert_allclose(np.asarray(obs[..., 2]), np.broadcast_to(budget[:, None, None], (200, 5, 5)) / 64.0)
    assert ENERGY_SCALE == 64.0
    np.testing.assert_array_equal(np.asarray(obs[..., 0]), np.asarray(obs_t[..., 0]))  # items unchanged
    agent_t, agent_g = np.asarray(obs_t[..., 1]), np.asarray(obs[..., 1])
    np.testing.assert_allclose(agent_g, np.where(agent_t > 0, agent_t / 64.0, agent_t))  # opponent stays -1
    assert (agent_g == -1).any() and np.all(agent_g[:, 0, 0] == budget / 64.0)  # the collector starts in the base
    # the history holds scaled planes
    step = jax.jit(lambda k, s, a: step_batch(general, k, s, a, params))
    obs2, _, _, term, trunc, _ = step(jax.random.PRNGKey(1), st, jnp.full((200,), 4, jnp.int32))
    going = ~np.asarray(term | trunc)  # (a finished game shows its next game's first observation)
    assert going.sum() > 150
    np.testing.assert_allclose(np.asarray(obs2[..., 3])[going], agent_g[going])
    low, high = general.observation_bounds(params)
    assert high[0, 0, 2] == 25 / 64.0 and low[0, 0, 2] == 0.0 and high[0, 0, 1] == 25 / 64.0
    assert np.all(np.asarray(obs) <= high) and np.all(np.asarray(obs) >= low)


def test_a_network_reads_the_general_observation():
    env = DCG(history=3, observation="general")
    obs, _ = env.reset(jax.random.PRNGKey(0), env.make_params(energy_range=(8, 25)))
    for name in ("imnn", "omn_conn"):  # EMNN is IMNN's body with a third head
        net = build("dcg", name, history=3, state_channels=env.state_channels)
        params = net.init(jax.random.PRNGKey(0), obs[None])
        out = net.apply(params, obs[None])
        assert out[0].shape == (1, 9)
    vnn = build("dcg", "vnn", state_channels=3)
    p = vnn.init(jax.random.PRNGKey(0), obs[None])
    changed = obs.at[..., 2].set(0.5)  # VNN reads the budget plane (its state), not the history
    assert not np.allclose(vnn.apply(p, obs[None])[0], vnn.apply(p, changed[None])[0])


def test_the_faithful_default_is_unchanged():
    env = DCG()
    params = env.make_params()
    assert params.energy_range is None
    assert repr(env) == repr(DCG(observation="thesis")) and "observation" not in repr(env)
    assert env == DCG(observation="thesis") and env != DCG(observation="general")
    obs, state = env.reset(jax.random.PRNGKey(0), params)
    assert state.max_energy is None and obs.shape == (5, 5, 12)
    # the pytrees have their old leaves: None fields are no leaves
    assert len(jax.tree_util.tree_leaves(state)) == len(EnvState.__dataclass_fields__) - 1 + 3  # OpponentState: 4
    assert len(jax.tree_util.tree_leaves(params)) == 3
    # a fixed energy in the general observation: the budget plane is that energy
    g = DCG(observation="general")
    obs_g, st_g = g.reset(jax.random.PRNGKey(0), g.make_params(energy=15.0))
    assert st_g.max_energy is None and np.all(np.asarray(obs_g[..., 2]) == 15 / 64.0)
