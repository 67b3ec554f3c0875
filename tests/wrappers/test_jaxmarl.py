"""The JaxMARL-style adapter of the team DCG (jaxdc.wrappers.jaxmarl).

JaxMARL 0.2.0 cannot be a jaxdc extra: its dependency gymnax 1.0.1 requires ``gymnasium<1.4`` and jaxdc
requires ``gymnasium>=1.4`` (docs/ambiguities.md). So the contract of JaxMARL's ``MultiAgentEnv`` and of
its ``LogWrapper`` / MAPPO loops is reproduced here (what they read: agent names, dict observations and
actions, per-agent rewards and dones with ``"__all__"``, ``[num_agents]`` infos, ``get_avail_actions``,
the spaces, ``obs["world_state"]``); the last test runs the adapter through JaxMARL's own base class and
``LogWrapper`` where ``jaxmarl`` is importable (skipped otherwise).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.dcg.env import CAUGHT, RUNNING
from jaxdc.dcg.team import DCGTeam
from jaxdc.wrappers.jaxmarl import INFO_KEYS, JaxMARLTeam

K = 2


@pytest.fixture(scope="module")
def marl():
    env = DCGTeam(collectors=K)
    return JaxMARLTeam(env, env.make_params(max_steps=40))


def test_agents_spaces_and_reset(marl):
    assert marl.agents == ["agent_0", "agent_1"] and marl.num_agents == K
    obs, state = marl.reset(jax.random.PRNGKey(0))
    assert set(obs) == {"agent_0", "agent_1", "world_state"}
    for a in marl.agents:
        assert obs[a].shape == marl.observation_space(a).shape == (5, 5, 13)
        assert bool(marl.observation_space(a).contains(obs[a]))
        assert marl.action_space(a).n == 9
        assert bool(marl.action_space(a).contains(marl.action_space(a).sample(jax.random.PRNGKey(1))))
    assert obs["world_state"].shape == marl.world_state_space().shape
    assert bool(marl.world_state_space().contains(obs["world_state"]))
    np.testing.assert_array_equal(np.asarray(obs["world_state"]), np.asarray(marl.get_world_state(state)))
    assert marl.agent_classes == {"collector": ["agent_0", "agent_1"]}


def test_step_dicts_team_reward_and_dones(marl):
    obs, state = marl.reset(jax.random.PRNGKey(0))
    state = state.replace(collector_outcome=jnp.asarray([CAUGHT, RUNNING], jnp.int32))
    avail = marl.get_avail_actions(state)
    assert not bool(avail["agent_0"][1:].any()) and bool(avail["agent_1"].all())
    actions = {a: jnp.int32(0) for a in marl.agents}
    obs, state2, rewards, dones, infos = jax.jit(marl.step)(jax.random.PRNGKey(1), state, actions)
    assert set(rewards) == set(marl.agents) and set(dones) == set(marl.agents) | {"__all__"}
    assert float(rewards["agent_0"]) == float(rewards["agent_1"])  # the team reward to every agent
    assert bool(dones["agent_0"]) and dones["__all__"].shape == ()
    assert set(infos) == set(INFO_KEYS) and all(v.shape == (K,) for v in infos.values())
    with pytest.raises(ValueError, match="agent_1"):
        marl.step(jax.random.PRNGKey(1), state, {"agent_0": 0})


def test_per_collector_rewards_and_reset_state():
    env = DCGTeam(collectors=K, strategies=("patrol",))
    params = env.make_params()
    marl = JaxMARLTeam(env, params, reward="collector", world_state=False)
    obs, state = marl.reset(jax.random.PRNGKey(0))
    assert set(obs) == set(marl.agents)
    items = jnp.zeros((5, 5)).at[0, 1].set(1.0)
    state = state.replace(items=items, opponent=state.opponent.replace(pos=jnp.asarray([[4, 4]], jnp.int32)))
    _, fresh = marl.reset(jax.random.PRNGKey(9))
    right = 4  # grid.ACTIONS: stay, up, down, left, right, ...
    obs, state2, rewards, dones, infos = marl.step(jax.random.PRNGKey(1), state, {"agent_0": right, "agent_1": 0},
                                                   reset_state=fresh)
    assert float(rewards["agent_0"]) == 1.0 and float(rewards["agent_1"]) == 0.0
    assert bool(dones["__all__"])  # every item collected: cleared, and the reset state is handed back
    np.testing.assert_array_equal(np.asarray(state2.items), np.asarray(fresh.items))


def _log_rollout(env, steps=60):
    """What JaxMARL's LogWrapper and MAPPO loops do with an environment, under jit: stack per-agent rewards,
    reshape infos to the agents, batch observations by agent name, sample available actions."""

    @jax.jit
    def run(key):
        k0, k1 = jax.random.split(key)
        obs, state = env.reset(k0)

        def body(carry, key):
            obs, state, ret = carry
            ka, ks = jax.random.split(key)
            avail = env.get_avail_actions(state)
            keys = jax.random.split(ka, env.num_agents)
            actions = {a: jax.random.categorical(keys[i], jnp.where(avail[a], 0.0, -1e9))
                       for i, a in enumerate(env.agents)}
            obs, state, reward, done, info = env.step(ks, state, actions)
            ret = ret + jnp.stack([reward[a] for a in env.agents])
            batch = jnp.stack([obs[a] for a in env.agents])
            info = jax.tree_util.tree_map(lambda x: x.reshape((env.num_agents,)), info)
            return (obs, state, ret * (1 - done["__all__"])), (batch, done["__all__"], info["episode_reward"])

        return jax.lax.scan(body, (obs, state, jnp.zeros(env.num_agents)), jax.random.split(k1, steps))

    return run(jax.random.PRNGKey(5))


def test_the_jaxmarl_loop_contract_under_jit(marl):
    _, (batch, done, ep_reward) = _log_rollout(marl)
    assert batch.shape == (60, K, 5, 5, 13)
    assert np.all(np.isfinite(np.asarray(batch))) and bool(np.asarray(done).any())
    assert float(np.asarray(ep_reward).max()) > 0


def test_through_jaxmarls_own_base_class_and_log_wrapper():
    jaxmarl_env = pytest.importorskip("jaxmarl.environments.multi_agent_env")
    baselines = pytest.importorskip("jaxmarl.wrappers.baselines")

    class TeamMAE(JaxMARLTeam, jaxmarl_env.MultiAgentEnv):
        """The adapter as a JaxMARL MultiAgentEnv (the base's step, with its auto-reset)."""

        step = jaxmarl_env.MultiAgentEnv.step

    env = DCGTeam(collectors=K)
    marl = TeamMAE(env, env.make_params(max_steps=40))
    assert isinstance(marl, jaxmarl_env.MultiAgentEnv)
    logged = baselines.LogWrapper(marl)
    obs, state = logged.reset(jax.random.PRNGKey(0))
    actions = {a: jnp.int32(4) for a in marl.agents}
    step = jax.jit(logged.step)
    for i in range(45):
        obs, state, reward, done, info = step(jax.random.PRNGKey(i + 1), state, actions)
    assert info["returned_episode"].shape == (K,)
    assert bool(np.asarray(info["returned_episode_lengths"]).max() > 0)
    assert obs["agent_0"].shape == (5, 5, 13)
