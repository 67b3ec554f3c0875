"""Bad input to the team DCG is refused outside jit, naming the parameter, the value and the allowed range;
actions out of range are clipped and flagged (as in the DCG)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core.env import step_batch
from jaxdc.dcg.env import DCG
from jaxdc.dcg.team import MAX_COLLECTORS, MAX_OPPONENTS, DCGTeam
from jaxdc.wrappers.jaxmarl import JaxMARLTeam


@pytest.mark.parametrize("kwargs,error,match", [
    ({"collectors": 0}, ValueError, rf"collectors must be in \[1, {MAX_COLLECTORS}\], got 0"),
    ({"collectors": MAX_COLLECTORS + 1}, ValueError, rf"collectors must be in \[1, {MAX_COLLECTORS}\], got 5"),
    ({"collectors": 2.0}, TypeError, r"collectors must be an int in \[1, 4\], got 2.0"),
    ({"collectors": True}, TypeError, "collectors must be an int"),
    ({"opponents": 0}, ValueError, rf"opponents must be in \[1, {MAX_OPPONENTS}\], got 0"),
    ({"opponents": 9}, ValueError, r"opponents must be in \[1, 4\], got 9"),
    ({"opponents": "2"}, TypeError, "opponents must be an int"),
    ({"teammates": 1}, TypeError, "teammates must be a bool .*got 1"),
    ({"teammates": "yes"}, TypeError, "teammates must be a bool"),
    ({"obs_history": 0}, TypeError, "obs_history must be a bool"),
    ({"safe_base": "no"}, TypeError, "safe_base must be a bool"),
    ({"reward_when_caught": None}, TypeError, "reward_when_caught must be a bool"),
    ({"fog_target": "closest"}, ValueError, r"fog_target must be one of \('visible', 'nearest'\), got 'closest'"),
    ({"target_tie": "random"}, ValueError, r"target_tie must be one of \('index',\), got 'random'"),
    ({"grid_size": 1}, ValueError, "grid_size"),
    ({"strategies": ("nobody",)}, ValueError, "unknown strategy 'nobody'"),
    ({"colectors": 2}, TypeError, "colectors"),
])
def test_bad_constructor_arguments_are_refused(kwargs, error, match):
    with pytest.raises(error, match=match):
        DCGTeam(**kwargs)


def test_make_params_checks_as_the_dcg():
    with pytest.raises(ValueError, match="max_steps"):
        DCGTeam().make_params(max_steps=0)
    with pytest.raises(ValueError, match="energy_range: low"):
        DCGTeam().make_params(energy_range=(9, 3))


@pytest.mark.parametrize("actions", [jnp.int32(0), jnp.zeros(3, jnp.int32), jnp.zeros((2, 1), jnp.int32)])
def test_actions_of_the_wrong_shape_are_refused_at_trace_time(actions):
    env = DCGTeam(collectors=2)
    params = env.make_params()
    _, state = env.reset(jax.random.PRNGKey(0), params)
    with pytest.raises(ValueError, match=r"actions has shape \[.*\], but DCGTeam takes \[2\]"):
        env.step(jax.random.PRNGKey(1), state, actions, params)
    with pytest.raises(ValueError, match=r"but DCGTeam takes \[2\]"):
        jax.jit(env.step)(jax.random.PRNGKey(1), state, actions, params)
    batch = jax.tree_util.tree_map(lambda x: jnp.stack([x, x]), state)
    with pytest.raises(ValueError, match=r"but DCGTeam takes \[batch, 2\]"):
        step_batch(env, jax.random.PRNGKey(2), batch, jnp.zeros((2, 3), jnp.int32), params, reset_slots=1)


def test_out_of_range_actions_are_clipped_and_flagged():
    env = DCGTeam(collectors=3, strategies=("patrol",))
    params = env.make_params()
    _, state = env.reset(jax.random.PRNGKey(0), params)
    _, s2, _, _, _, info = env.step(jax.random.PRNGKey(1), state, jnp.asarray([-5, 4, 99]), params)
    np.testing.assert_array_equal(np.asarray(info["invalid_action"]), [True, False, True])
    # -5 -> stay (stays in the base), 99 -> down_right
    assert tuple(np.asarray(s2.pos[0])) == (0, 0) and tuple(np.asarray(s2.pos[2])) == (1, 1)


def test_a_state_or_params_of_another_game_is_refused():
    env = DCGTeam(collectors=2)
    params = env.make_params()
    _, dcg_state = DCG().reset(jax.random.PRNGKey(0), params)
    with pytest.raises(TypeError, match="state must be the TeamState"):
        env.step(jax.random.PRNGKey(1), dcg_state, jnp.zeros(2, jnp.int32), params)
    _, three = DCGTeam(collectors=3).reset(jax.random.PRNGKey(0), params)
    with pytest.raises(ValueError, match=r"state.history has shape \(3, 5, 5, 10\)"):
        env.step(jax.random.PRNGKey(1), three, jnp.zeros(2, jnp.int32), params)


def test_the_adapter_refuses_what_is_not_a_team_game():
    with pytest.raises(TypeError, match="env must be a DCGTeam, got DCG"):
        JaxMARLTeam(DCG())
    with pytest.raises(ValueError, match=r"reward must be one of \('team', 'collector'\), got 'mine'"):
        JaxMARLTeam(DCGTeam(), reward="mine")
    with pytest.raises(TypeError, match="world_state must be a bool"):
        JaxMARLTeam(DCGTeam(), world_state=1)
