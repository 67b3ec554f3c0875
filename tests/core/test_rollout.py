"""run_episodes: frozen final states, lane-count independence, determinism."""

import jax
import numpy as np

from jaxdc.core import grid, rollout
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


def _stay(key, obs, state):
    return jax.numpy.int32(grid.STAY)  # staying put without risk or energy limit: a game ends at the step cap


def test_progress_reaches_the_reporter_and_changes_nothing(monkeypatch):
    # a long evaluation (games that only end at a large step cap) reports its progress from inside the loop
    monkeypatch.setattr(rollout, "HEARTBEAT_EVERY", 64)
    env = DCP(grid_size=5, total_reward=6)
    params = env.make_params(np.zeros((5, 5)), (float("inf"), float("inf")), max_steps=1000)

    def run(key):  # traced afresh at each call (a new jit wrapper)
        return jax.block_until_ready(jax.jit(lambda k: run_episodes(env, params, _stay, k, 10, lanes=4))(key))

    quiet = run(jax.random.PRNGKey(0))
    reports = []
    with rollout.reporting(lambda *r: reports.append(r)):
        loud = run(jax.random.PRNGKey(0))
    assert rollout._reporters == []
    # 10 games of 1,000 steps on 4 lanes: 3 rounds of 1,000 iterations, a report every 64
    assert [r[2] for r in reports] == list(range(64, 3000, 64))
    assert all(r[1] == 10 for r in reports)
    finished = [r[0] for r in reports]
    assert finished == sorted(finished) and finished[0] == 0 and finished[-1] == 8
    for x, y in zip(jax.tree_util.tree_leaves(quiet), jax.tree_util.tree_leaves(loud)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    # a loop traced outside any block carries no progress call, so it stays silent inside one
    silent = jax.jit(lambda k: run_episodes(env, params, _stay, k, 10, lanes=4))
    jax.block_until_ready(silent(jax.random.PRNGKey(1)))
    n = len(reports)
    with rollout.reporting(lambda *r: reports.append(r)):
        jax.block_until_ready(silent(jax.random.PRNGKey(2)))
    assert len(reports) == n
