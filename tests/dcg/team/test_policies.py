"""The team yardsticks (jaxdc.dcg.team.policies, jaxdc.dcg.analysis.team)."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import grid
from jaxdc.core.rollout import run_episodes
from jaxdc.dcg import DCG
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis import team as team_analysis
from jaxdc.dcg.env import ENERGY
from jaxdc.dcg.evaluate import evaluate_network
from jaxdc.dcg.team import DCGTeam
from jaxdc.dcg.team.policies import copies, greedy_split


def test_one_copy_plays_exactly_the_one_collector_evaluation():
    learned = learned_lib.shipped("vnn")
    single, params = learned.game()
    key = jax.random.PRNGKey(3)
    one = evaluate_network(single, params, learned.net, learned.params, key, episodes=64, lanes=32)
    env, team_params = team_analysis.team_game(learned, 1)
    team = jax.jit(lambda k: run_episodes(env, team_params, copies(learned.policy(), 1), k, 64, 32))(key)
    np.testing.assert_array_equal(np.asarray(team.ep_reward), np.asarray(one.game.ep_reward))
    np.testing.assert_array_equal(np.asarray(team.time), np.asarray(one.game.time))


def test_copies_act_from_their_own_seats():
    env = DCGTeam(collectors=2, teammates=False, grid_size=4, strategies=("patrol",), history=1, obs_history=False)
    params = env.make_params()
    obs, state = env.reset_env(jax.random.PRNGKey(0), params)
    seen = copies(lambda k, o, s: jnp.int32(s.pos[0] * 4 + s.pos[1] + 10 * (o.shape[-1] - 2)), 2)
    state = dataclasses.replace(state, pos=jnp.asarray([[1, 2], [3, 0]], jnp.int32))
    np.testing.assert_array_equal(np.asarray(seen(jax.random.PRNGKey(1), obs, state)), [6, 12])


def _state(env, params, pos, energy, items):
    _, state = env.reset_env(jax.random.PRNGKey(0), params)
    return dataclasses.replace(state, pos=jnp.asarray(pos, jnp.int32), energy=jnp.asarray(energy, jnp.float32),
                               items=jnp.asarray(items, jnp.float32))


def test_the_scripted_collectors_split_the_items():
    env = DCGTeam(collectors=2, grid_size=5, strategies=("patrol",), history=1, obs_history=False)
    params = env.make_params(energy=15.0)
    items = np.zeros((5, 5))
    items[0, 4] = items[4, 0] = 1
    state = _state(env, params, [[0, 0], [0, 0]], [15.0, 15.0], items)
    actions = np.asarray(greedy_split(5, 2)(jax.random.PRNGKey(0), None, state))
    # both items are 4 moves away; collector 0 takes the first in row-major order (0, 4), collector 1 the other
    towards = [int(grid.shortest_move(jnp.zeros(2, jnp.int32), jnp.asarray(c), 5)) for c in ([0, 4], [4, 0])]
    assert actions.tolist() == towards and towards[0] != towards[1]


def test_a_scripted_collector_turns_home_before_it_is_stranded():
    env = DCGTeam(collectors=1, grid_size=5, strategies=("patrol",), history=1, obs_history=False)
    params = env.make_params(energy=15.0)
    items = np.zeros((5, 5))
    items[4, 4] = 1
    policy = greedy_split(5, 1)
    onward = policy(jax.random.PRNGKey(0), None, _state(env, params, [[2, 2]], [4.0], items))
    home = policy(jax.random.PRNGKey(0), None, _state(env, params, [[2, 2]], [3.0], items))
    here = jnp.asarray([2, 2], jnp.int32)
    # energy 4: after the move to (3, 3) 3 units remain, enough for the 3 moves home; energy 3: not enough
    assert int(onward[0]) == int(grid.shortest_move(here, jnp.asarray([4, 4]), 5))
    assert int(home[0]) == int(grid.shortest_move(here, jnp.asarray([0, 0]), 5))


@pytest.mark.parametrize("collectors", [1, 3])
def test_scripted_collectors_never_run_out_of_energy(collectors):
    env = DCGTeam(collectors=collectors, grid_size=5, strategies=("patrol",), history=1, obs_history=False)
    params = env.make_params(energy=6.0, max_steps=60)
    out = jax.jit(lambda k: run_episodes(env, params, greedy_split(5, collectors), k, 200, 100))(
        jax.random.PRNGKey(2))
    assert not np.any(np.asarray(out.collector_outcome) == ENERGY)
    assert float(np.mean(np.asarray(out.ep_reward))) > 0


def test_evaluate_team_summarises_and_refuses_a_one_collector_game():
    env = DCGTeam(collectors=2, grid_size=4, total_reward=4, history=1, obs_history=False)
    params = env.make_params(energy=8.0, max_steps=40)
    out = team_analysis.evaluate_team(env, params, greedy_split(4, 2), jax.random.PRNGKey(0), 50)
    assert out["collectors"] == 2 and out["episodes"] == 50
    assert 0 <= out["reward"]["mean"] <= 4 and out["reward"]["se"] > 0
    assert 0 <= out["caught_collectors"] <= out["any_caught"] <= 1
    assert set(out["per_strategy"]) == set(env.strategies)
    with pytest.raises(TypeError, match="DCGTeam"):
        team_analysis.evaluate_team(DCG(grid_size=4), params, greedy_split(4, 2), jax.random.PRNGKey(0), 5)
    with pytest.raises(ValueError, match="episodes"):
        team_analysis.evaluate_team(env, params, greedy_split(4, 2), jax.random.PRNGKey(0), 0)
