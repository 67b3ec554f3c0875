"""Action masks (jaxdc.dcp.masks) and the masked policies of the learners (agents.a2c / agents.nstep_q)."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.agents import a2c, nstep_q
from jaxdc.core import grid
from jaxdc.core.rollout import run_episodes
from jaxdc.dcp import masks
from jaxdc.dcp.env import DCP, ENERGY
from jaxdc.nets.linear import Linear

A = {name: i for i, name in enumerate(grid.ACTIONS)}


def _allowed(mask, state):
    return {name for name, ok in zip(grid.ACTIONS, np.asarray(mask(state))) if ok}


def test_reach_base_forbids_exactly_the_moves_that_strand_the_agent(state_builder):
    env = DCP(grid_size=8, total_reward=3)
    mask = masks.reach_base(env)
    # (3, 3) holding 4: a move leaves 3, enough for a cell 3 moves from the base, not for one 4 moves away
    state = state_builder(env, (3, 3), 4.0, {(7, 7): 1.0})
    assert _allowed(mask, state) == set(grid.ACTIONS) - {"down", "right", "down_left", "up_right", "down_right"}
    # with one more unit every move is allowed; at the base a full budget allows everything
    assert _allowed(mask, state_builder(env, (3, 3), 5.0, {(7, 7): 1.0})) == set(grid.ACTIONS)
    assert _allowed(mask, state_builder(env, (0, 0), 2.0, {(7, 7): 1.0})) == set(grid.ACTIONS)
    # energy 2 next to the base: only the base itself and cells 1 move away (2 - 1 >= 1)
    state = state_builder(env, (1, 1), 2.0, {(7, 7): 1.0})
    assert _allowed(mask, state) == {"stay", "up", "left", "up_left"}
    # energy 1 next to the base: only the base
    assert _allowed(mask, state_builder(env, (1, 1), 1.0, {(7, 7): 1.0})) == {"up_left"}
    # stranded already (5 moves out with 2): nothing is safe, so nothing is forbidden
    assert _allowed(mask, state_builder(env, (5, 5), 2.0, {(7, 7): 1.0})) == set(grid.ACTIONS)
    # unlimited energy forbids nothing
    assert _allowed(mask, state_builder(env, (6, 6), math.inf, {(7, 7): 1.0})) == set(grid.ACTIONS)


def test_reach_base_or_item_also_allows_taking_or_reaching_an_item(state_builder):
    env = DCP(grid_size=8, total_reward=3)
    state = state_builder(env, (2, 2), 3.0, {(3, 3): 1.0})
    strict, loose = masks.reach_base(env), masks.reach_base_or_item(env)
    assert "down_right" not in _allowed(strict, state)  # 3 moves from home with 2 left
    assert "down_right" in _allowed(loose, state)  # but it takes the item there
    # an item 2 moves beyond the next cell is reachable with the 2 units that remain after the move
    state = state_builder(env, (2, 2), 3.0, {(5, 5): 1.0})
    assert "down_right" not in _allowed(strict, state) and "down_right" in _allowed(loose, state)
    assert _allowed(loose, state_builder(env, (2, 2), 2.0, {(5, 5): 1.0})) == _allowed(
        strict, state_builder(env, (2, 2), 2.0, {(5, 5): 1.0}))


def test_make_mask_names_the_choices():
    env = DCP(grid_size=4, total_reward=2)
    assert masks.make_mask("none", env) is None
    with pytest.raises(ValueError, match="mask must be one of"):
        masks.make_mask("reach_home", env)


def _energy_deaths(env, params, mask):
    net = Linear()
    obs, _ = env.reset(jax.random.PRNGKey(0), params)
    net_params = net.init(jax.random.PRNGKey(1), obs[None], jnp.zeros((1, 1, 9)))
    policy = a2c.make_policy(net, net_params, mask=mask)
    final = jax.jit(lambda key: run_episodes(env, params, policy, key, 200))(jax.random.PRNGKey(2))  # not op by op
    return int(np.sum(np.asarray(final.outcome) == ENERGY))


def test_a_masked_policy_starting_in_the_base_never_runs_dry():
    env = DCP(grid_size=6, total_reward=4, start="base")
    params = env.make_params(np.zeros((6, 6), np.float32), (3.0, 3.0))
    assert _energy_deaths(env, params, None) > 0  # a random linear policy strands itself
    assert _energy_deaths(env, params, masks.reach_base(env)) == 0


def test_epsilon_greedy_keeps_to_the_allowed_actions():
    q = jnp.tile(jnp.arange(9.0), (4000, 1))  # the argmax would be action 8
    allowed = jnp.zeros((4000, 9), bool).at[:, 2].set(True).at[:, 5].set(True)
    acts = np.asarray(nstep_q.epsilon_greedy(jax.random.PRNGKey(0), q, 0.5, allowed))
    assert set(acts.tolist()) == {2, 5} and np.mean(acts == 5) > 0.7  # greedy 5, exploring 2 or 5
    acts = np.asarray(nstep_q.epsilon_greedy(jax.random.PRNGKey(0), q, 1.0))
    assert len(set(acts.tolist())) == 9  # unmasked exploration still covers every action


def test_evaluate_learned_refuses_an_unknown_mask():
    from jaxdc import pretrained
    from jaxdc.dcp import instances, learned
    from jaxdc.dcp.evaluate import evaluate_learned

    net = learned.load(pretrained.shipped("dcp", "enn_general"))
    env = DCP(grid_size=8, total_reward=2, observation="general")
    params = instances.fixed_instance(env, np.zeros((8, 8), np.float32), (4.0, 8.0))
    with pytest.raises(ValueError, match=r"mask must be one of \('none', 'reach_base', 'reach_base_or_item'\)"):
        evaluate_learned(env, params, net, jax.random.PRNGKey(0), 10, mask="reach_home")
