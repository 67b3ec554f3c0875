"""MAPPO: the team trainer of jaxdc.agents.a2c with a centralised critic on the world state
(make_train(..., critic=...), jaxdc.agents.centralised, jaxdc.nets.critic; beyond the thesis, issue 29)."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.agents import a2c
from jaxdc.agents.centralised import CRITIC, CentralCritic, actor_params
from jaxdc.core.tree_check import digest
from jaxdc.dcg import DCG
from jaxdc.dcg.learned import opponent_labels
from jaxdc.dcg.team import DCGTeam
from jaxdc.nets import build
from jaxdc.nets.critic import WorldCritic
from jaxdc.nets.registry import ALGOS, build_critic

GAME = dict(grid_size=4, total_reward=4, strategies=("patrol", "restricted"), history=2)
PPO = dict(gae_lambda=0.95, clip_eps=0.2, epochs=2, minibatches=2, normalize_advantages=True)


def _config(**kw):
    return a2c.A2CConfig(total_steps=4 * 8 * 3, num_envs=4, t_max=8, lr=1e-3, **kw)


def _trainer(net_name="omn_conn", critic=True, options=PPO, **env_kw):
    env = DCGTeam(collectors=2, **{**GAME, **env_kw})
    net = build("dcg", net_name, history=2, state_channels=env.state_channels)
    aux = opponent_labels(2) if net.has_aux else None
    trainer = a2c.make_train(_config(**options), env, env.make_params(energy=6.0, max_steps=20), net,
                             aux_target=aux, critic=WorldCritic() if critic else None)
    return env, net, trainer


def test_the_registry_names_the_team_learners():
    assert tuple(ALGOS) == ("ippo", "mappo")
    assert build_critic("ippo") is None and isinstance(build_critic("mappo"), WorldCritic)
    with pytest.raises(ValueError, match=r"algo must be one of \('ippo', 'mappo'\), got 'qmix'"):
        build_critic("qmix")


@pytest.mark.parametrize("options", [{}, PPO], ids=["a2c", "ppo"])
def test_a_tiny_mappo_run_trains_its_critic_and_not_the_actors_value_head(options):
    env, net, trainer = _trainer("vnn", options=options)
    start = trainer.init(jax.random.PRNGKey(1))
    assert set(start.params["params"]) == {"body", "policy_out", "value_out", CRITIC}
    state, metrics = trainer.run(start, 3)
    for name in ("loss", "policy_loss", "value_loss", "entropy"):
        assert np.all(np.isfinite(np.asarray(metrics[name]))), name
    before, after = start.params["params"], state.params["params"]
    moved = lambda a, b: any(not np.array_equal(x, y) for x, y in zip(  # noqa: E731
        jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)))
    # the critic and the policy learn; the actor's own value head is not used (no gradient: Adam leaves it)
    assert moved(before[CRITIC], after[CRITIC]) and moved(before["policy_out"], after["policy_out"])
    assert not moved(before["value_out"], after["value_out"])


def test_ippo_trains_the_actors_value_head_and_has_no_critic():
    """The control of the test above: without a critic the value head does learn."""
    _, _, trainer = _trainer("vnn", critic=False)
    start = trainer.init(jax.random.PRNGKey(1))
    assert CRITIC not in start.params["params"]
    state, _ = trainer.run(start, 3)
    assert not np.array_equal(np.asarray(start.params["params"]["value_out"]["kernel"]),
                              np.asarray(state.params["params"]["value_out"]["kernel"]))


def test_mappo_starts_exactly_as_ippo_and_then_learns_differently():
    """The critic's key is folded from the run's: the actor, the games and the training key are IPPO's."""
    _, _, mappo = _trainer()
    _, _, ippo_again = _trainer(critic=False)
    a, b = ippo_again.init(jax.random.PRNGKey(5)), mappo.init(jax.random.PRNGKey(5))
    assert digest(a.params) == digest(actor_params(b.params)) and digest(a.params) != digest(b.params)
    for field in ("obs", "key"):
        np.testing.assert_array_equal(np.asarray(getattr(a, field)), np.asarray(getattr(b, field)))
    (sa, ma), (sb, mb) = ippo_again.update(a), mappo.update(b)
    assert float(ma["episode_reward_sum"]) == float(mb["episode_reward_sum"])  # the same first rollout
    assert float(ma["value_loss"]) != float(mb["value_loss"])  # another critic
    assert digest(sa.params) != digest(actor_params(sb.params))


def test_the_same_seed_gives_the_same_numbers():
    first, second = _trainer()[2], _trainer()[2]  # built apart
    runs = []
    for trainer, seed in ((first, 3), (second, 3), (second, 4)):
        state, metrics = trainer.train(jax.random.PRNGKey(seed))
        runs.append((digest(state.params), np.asarray(metrics["loss"])))
    assert runs[0][0] == runs[1][0]
    np.testing.assert_array_equal(runs[0][1], runs[1][1])
    assert runs[2][0] != runs[0][0]


def test_the_critic_reads_the_world_state_and_ippo_the_own_observation():
    """teammates=False: collector 0's observation does not show collector 1, so moving collector 1 leaves row 0's
    IPPO value unchanged, while the world state -- and the centralised critic's value -- change."""
    env = DCGTeam(collectors=2, teammates=False, **GAME)
    params = env.make_params(energy=6.0, max_steps=20)
    net = build("dcg", "vnn", history=2, state_channels=env.state_channels)
    central = CentralCritic.of(WorldCritic(), env, params, 2)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    obs = env.observe(state, params)
    moved = dataclasses.replace(state, pos=state.pos.at[1].set(jnp.asarray([2, 3])))
    states = jax.tree_util.tree_map(lambda x, y: jnp.stack([x, y]), state, moved)
    actor = net.init(jax.random.PRNGKey(1), obs)
    tree = central.init(jax.random.PRNGKey(2), states, actor)
    world = central.world(states)
    assert world.shape == (2,) + env.world_state_shape()
    assert not np.array_equal(np.asarray(world[0]), np.asarray(world[1]))
    v = np.asarray(central.value(tree, world))
    assert v.shape == (2,) and v[0] != v[1]
    np.testing.assert_array_equal(np.asarray(central.row_values(tree, world)), np.repeat(v, 2))
    obs_moved = env.observe(moved, params)
    np.testing.assert_array_equal(np.asarray(obs[0]), np.asarray(obs_moved[0]))  # row 0 does not see it
    own = net.apply(tree, jnp.stack([obs[0], obs_moved[0]]), method="value")
    assert float(own[0]) == float(own[1])


def test_a_truncated_episode_bootstraps_from_the_world_state_before_the_reset():
    """info["world_state"] is the world state the step reached, before the auto-reset: the critic's bootstrap."""
    env = DCGTeam(collectors=2, **GAME)
    params = env.make_params(energy=6.0, max_steps=1)
    # jitted (the same functions; op by op each call dispatched and compiled hundreds of primitives)
    reset, step_env, step, world_state = (jax.jit(f) for f in (env.reset, env.step_env, env.step, env.world_state))
    _, state = reset(jax.random.PRNGKey(0), params)
    actions = jnp.asarray([2, 4])  # down, right: both leave the base
    k_step, _ = jax.random.split(jax.random.PRNGKey(2))  # Environment.step's key of step_env
    stepped = step_env(k_step, state, actions, params)[1]
    _, fresh, _, _, trunc, info = step(jax.random.PRNGKey(2), state, actions, params)
    assert bool(trunc) and int(fresh.time) == 0
    np.testing.assert_array_equal(np.asarray(info["world_state"]), np.asarray(world_state(stepped, params)))
    assert not np.array_equal(np.asarray(info["world_state"]), np.asarray(world_state(fresh, params)))


def test_a_critic_is_refused_where_there_is_no_team_world_state():
    single = DCG(**GAME)
    net = build("dcg", "vnn")
    with pytest.raises(ValueError, match="critic: a centralised critic reads a team's world state"):
        a2c.make_train(_config(), single, single.make_params(), net, critic=WorldCritic())
    env = DCGTeam(collectors=2, **GAME)
    with pytest.raises(TypeError, match="critic must be a flax module"):
        a2c.make_train(_config(), env, env.make_params(), build("dcg", "vnn", state_channels=3), critic="mappo")


def test_init_params_warm_start_the_actor_and_the_critic_starts_fresh():
    env, net, trainer = _trainer()
    fresh = trainer.init(jax.random.PRNGKey(0))
    start = jax.tree_util.tree_map(lambda x: x + 1.0, actor_params(fresh.params))
    warm = a2c.make_train(_config(**PPO), env, env.make_params(energy=6.0, max_steps=20), net,
                          aux_target=opponent_labels(2), critic=WorldCritic(), init_params=start).init(
        jax.random.PRNGKey(0))
    assert digest(actor_params(warm.params)) == digest(start)
    assert digest(warm.params["params"][CRITIC]) == digest(fresh.params["params"][CRITIC])
    with pytest.raises(ValueError, match="init_params"):  # the actor's tree, not the trained one with the critic
        a2c.make_train(_config(), env, env.make_params(energy=6.0, max_steps=20), net,
                       aux_target=opponent_labels(2), critic=WorldCritic(), init_params=fresh.params)


def test_actor_params_drops_only_the_critic():
    tree = {"params": {"body": {"w": jnp.ones(2)}, CRITIC: {"v": jnp.zeros(1)}}}
    assert set(actor_params(tree)["params"]) == {"body"}
    plain = {"params": {"body": {"w": jnp.ones(2)}}}
    assert actor_params(plain) is plain
