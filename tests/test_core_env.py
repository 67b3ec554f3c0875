"""core.env: auto-reset in Environment.step and step_batch with few reset slots."""

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
