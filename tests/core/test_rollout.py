"""run_episodes: frozen final states, lane-count independence, determinism."""

import jax
import numpy as np

from jaxdc.core.paths import safest_paths
from jaxdc.core.rollout import run_episodes
from jaxdc.dcp import navigators
from jaxdc.dcp.env import DCP, RUNNING

ENV = DCP(grid_size=5, total_reward=6, idle_terminates=True)
PARAMS = ENV.make_params("high", (4.0, 8.0), max_steps=40)
TABLE = safest_paths(PARAMS.risk)


def _policy(key, obs, state):
    # a stochastic policy: the navigator's action, or a random one 30% of the time
    k1, k2 = jax.random.split(key)
    nav = navigators.navigator_action("safe_reward", state, TABLE)
    return jax.numpy.where(jax.random.uniform(k1) < 0.3, jax.random.randint(k2, (), 0, 9), nav)


RUN = jax.jit(lambda key, lanes: run_episodes(ENV, PARAMS, _policy, key, 300, lanes), static_argnums=1)


def test_results_do_not_depend_on_lanes():
    a = RUN(jax.random.PRNGKey(0), 300)
    b = RUN(jax.random.PRNGKey(0), 7)
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_every_episode_finished_and_seed_matters():
    a = RUN(jax.random.PRNGKey(0), 64)
    assert np.all(np.asarray(a.outcome) != RUNNING)
    assert np.all(np.asarray(a.time) <= 40)
    c = RUN(jax.random.PRNGKey(1), 64)
    assert not np.array_equal(np.asarray(a.ep_reward), np.asarray(c.ep_reward))
