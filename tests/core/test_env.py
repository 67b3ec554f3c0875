"""core.env: auto-reset in Environment.step and step_batch with few reset slots."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core.env import step_batch
from jaxdc.dcp.env import DCP, RUNNING

ENV = DCP(grid_size=4, total_reward=3)
# risk 1 everywhere but the base: every step out of the base ends the episode
RISK = np.ones((4, 4), np.float32)
RISK[0, 0] = 0.0
PARAMS = ENV.make_params(RISK, (5.0, 5.0), max_steps=50)
B = 8


def _states():
    return jax.vmap(ENV.reset, in_axes=(0, None))(jax.random.split(jax.random.PRNGKey(0), B), PARAMS)[1]


STEP = jax.jit(lambda key, s, a, k: step_batch(ENV, key, s, a, PARAMS, k), static_argnums=3)


@pytest.mark.parametrize("slots", [None, 2, 8])
def test_finished_envs_restart_and_others_continue(slots):
    s = _states()
    # env 0 stays in the base cell if it starts there; every other env dies on its step
    action = jnp.zeros(B, jnp.int32)
    obs, s2, r, term, trunc, info = STEP(jax.random.PRNGKey(1), s, action, slots)
    done = np.asarray(term | trunc)
    at_base = np.all(np.asarray(s.pos) == 0, axis=1)
    np.testing.assert_array_equal(done, ~at_base)  # risk 1 off the base, 0 on it
    assert np.all(np.asarray(s2.time)[done] == 0) and np.all(np.asarray(s2.outcome) == RUNNING)
    assert np.all(np.asarray(s2.time)[~done] == 1)
    # the final observation of finished envs is the one of the ended episode
    np.testing.assert_array_equal(np.asarray(info["final_observation"])[~done], np.asarray(obs)[~done])
    # fresh episodes get distinct item layouts (independent initial states), in both paths
    fresh = np.asarray(s2.items)[done]
    assert len({f.tobytes() for f in fresh}) == len(fresh)


def test_step_batch_deterministic_and_fallback_used_when_slots_short():
    s = _states()
    a = jnp.full(B, 4, jnp.int32)
    x = STEP(jax.random.PRNGKey(2), s, a, 1)  # more than one env finishes: the fallback path
    y = STEP(jax.random.PRNGKey(2), s, a, 1)
    for u, v in zip(jax.tree_util.tree_leaves(x), jax.tree_util.tree_leaves(y)):
        np.testing.assert_array_equal(np.asarray(u), np.asarray(v))
    assert int(np.sum(np.asarray(x[3]))) > 1
    assert np.all(np.asarray(x[1].time)[np.asarray(x[3])] == 0)


# -- the auto-reset under vmap (core.env.reset_where) -------------------------------------------------------
def _unbatched_steps(env, keys, state, action, params):
    """``env.step`` for each environment alone (a Python loop of unbatched steps, each jitted on its own), stacked."""
    step = jax.jit(env.step)
    outs = [step(keys[i], jax.tree_util.tree_map(lambda x, i=i: x[i], state), action[i], params)
            for i in range(keys.shape[0])]
    return jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *outs)


def _games():
    from jaxdc.dcg.env import DCG
    from jaxdc.dcp.env import DCP

    dcp = DCP(grid_size=4, total_reward=6)
    dcg = DCG(grid_size=4, total_reward=4)
    return [(dcp, dcp.make_params("high", (2.0, 3.0), max_steps=5)), (dcg, dcg.make_params(energy=3.0, max_steps=5))]


@pytest.mark.parametrize("chunk", [1, 3, None])
@pytest.mark.parametrize("game", [0, 1], ids=["dcp", "dcg"])
def test_batched_auto_reset_equals_the_unbatched_step(game, chunk, monkeypatch):
    """vmap(env.step) resets only the finished environments, ``reset_chunk`` at a time (several passes when more
    finish), and gives exactly what each environment's own step gives."""
    env, params = _games()[game]
    monkeypatch.setattr(env, "reset_chunk", chunk)
    b = 12
    key = jax.random.PRNGKey(7)
    _, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(key, b), params)
    step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
    finished = 0
    for t in range(6):
        keys = jax.random.split(jax.random.fold_in(key, t), b)
        action = jax.random.randint(jax.random.fold_in(key, 100 + t), (b,), 0, 9)
        got = step(keys, state, action, params)
        want = _unbatched_steps(env, keys, state, action, params)
        chex.assert_trees_all_equal(got, want)
        finished += int(jnp.sum(got[3] | got[4]))
        state = got[1]
    assert finished > 3  # several environments finished, some on the same step: the reset path ran


def test_batched_auto_reset_with_per_environment_params_and_nested_vmap():
    env, params = _games()[0]
    b = 6
    risks = jnp.stack([params.risk * f for f in jnp.linspace(0.2, 1.0, b)])
    batch_params = jax.tree_util.tree_map(lambda x: jnp.stack([x] * b), params).replace(risk=risks)
    key = jax.random.PRNGKey(3)
    keys = jax.random.split(key, b)
    _, state = jax.vmap(env.reset)(keys, batch_params)
    action = jnp.arange(b) % 9
    got = jax.jit(jax.vmap(env.step))(keys, state, action, batch_params)  # params batched: the reset-all path
    want = [env.step(keys[i], jax.tree_util.tree_map(lambda x, i=i: x[i], state), action[i],
                     jax.tree_util.tree_map(lambda x, i=i: x[i], batch_params)) for i in range(b)]
    chex.assert_trees_all_equal(got, jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *want))
    # vmap over seeds of vmap over environments (agents.parallel): the same as each inner batch alone
    inner = jax.vmap(env.step, in_axes=(0, 0, 0, None))
    keys2 = jnp.stack([keys, jax.random.split(jax.random.PRNGKey(4), b)])
    state2 = jax.tree_util.tree_map(lambda x: jnp.stack([x, x]), state)
    action2 = jnp.stack([action, action[::-1]])
    nested = jax.jit(jax.vmap(inner, in_axes=(0, 0, 0, None)))(keys2, state2, action2, params)
    for s in range(2):
        one = inner(keys2[s], jax.tree_util.tree_map(lambda x, s=s: x[s], state2), action2[s], params)
        chex.assert_trees_all_equal(jax.tree_util.tree_map(lambda x, s=s: x[s], nested), one)


def test_reset_chunk_is_part_of_the_static_key():
    """``reset_chunk`` changes the compiled auto-reset, so environments that differ in it neither compare nor hash
    equal (they are static arguments of jitted functions)."""
    a, b = DCP(grid_size=4, total_reward=3), DCP(grid_size=4, total_reward=3)
    assert a == b and hash(a) == hash(b)
    b.reset_chunk = 2
    assert a != b and hash(a) != hash(b)
    a.reset_chunk = 2
    assert a == b and hash(a) == hash(b)
