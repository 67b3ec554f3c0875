"""The two-collector search (:mod:`jaxdc.dcg.exact.team`) against the team env (:class:`jaxdc.dcg.team.DCGTeam`).

The search was written from the rules alone and checked against a plain-Python brute force
(test_team.py); here its optimal joint plans are played in the real team env, from the reset state the
env draws with the same key, and must earn the search's value along the same trajectory: the same
reward each step, the same opponent and active collectors, and the same cells while a collector is
active (the search stores no cell for a disabled collector or a finished game).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.dcg import DCG
from jaxdc.dcg.exact import many_items, team
from jaxdc.dcg.team import DCGTeam

STRATEGIES = ("patrol", "restricted", "with_fog", "double_blind")


@pytest.mark.parametrize("fog_target", team.FOG_TARGETS)
@pytest.mark.parametrize("strategy", STRATEGIES)
def test_optimal_plans_earn_the_optimum_in_the_team_env(strategy, fog_target):
    options = dict(grid_size=3, total_reward=3, strategies=(strategy,), history=1, obs_history=False)
    single = DCG(**options)
    env = DCGTeam(collectors=2, opponents=1, fog_target=fog_target, **options)
    params = single.make_params(energy=3.0, max_steps=8, chase_tie="straight")
    machines = many_items.opponent_machines(single, params)
    step = jax.jit(env.step_env)
    earned_something = 0
    for seed in range(6):
        key = jax.random.PRNGKey(seed)
        _, state = env.reset_env(key, params)
        _, one = single.reset_env(key, params)  # the search's game: the same drop and opponent
        np.testing.assert_array_equal(np.asarray(state.items), np.asarray(one.items))
        opt = team.game_optimum(single, machines, one, fog_target)
        trace = team.replay(single, machines, one, opt.plan, fog_target)
        total, done = 0.0, False
        for t, actions in enumerate(opt.plan):
            assert not done, "the env ended the game before the plan did"
            _, state, reward, terminated, truncated, _ = step(jax.random.PRNGKey(100 + t), state,
                                                               jnp.asarray(actions, jnp.int32), params)
            total += float(reward)
            done = bool(terminated | truncated)
            assert float(reward) == trace["reward"][t]
            np.testing.assert_array_equal(np.asarray(state.opponent.pos[0]), trace["opponent"][t + 1])
            np.testing.assert_array_equal(np.asarray(state.active), trace["active"][t + 1])
            if not done:  # the search keeps no cell for a disabled collector or a finished game
                moving = np.asarray(state.active)
                np.testing.assert_array_equal(np.asarray(state.pos)[moving], trace["pos"][t + 1][moving])
        assert total == pytest.approx(opt.reward)
        earned_something += opt.reward > 0
    assert earned_something  # the games are not all empty
