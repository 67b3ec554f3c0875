"""A2C on a team environment (jaxdc.agents.a2c, its "Teams" docs): the k agents are k rows of one batch."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.agents import a2c
from jaxdc.dcg import DCG
from jaxdc.dcg.learned import opponent_labels
from jaxdc.dcg.team import DCGTeam
from jaxdc.nets import build

GAME = dict(grid_size=4, total_reward=4, strategies=("patrol", "restricted"), history=2)
PPO = dict(gae_lambda=0.95, clip_eps=0.2, epochs=2, minibatches=2, normalize_advantages=True)


def _config(**kw):
    return a2c.A2CConfig(total_steps=4 * 8 * 3, num_envs=4, t_max=8, lr=1e-3, **kw)


@pytest.mark.parametrize("options", [{}, PPO], ids=["a2c", "ppo"])
def test_a_team_of_one_trains_exactly_as_the_one_collector_game(options):
    """DCGTeam(collectors=1) is the DCG step for step; its rows are the one-collector batch, every weight 1."""
    config = _config(**options)
    net = build("dcg", "omn_conn", history=2, state_channels=2)
    single = DCG(**GAME)
    team = DCGTeam(collectors=1, **GAME)
    assert not team.teammates
    out = []
    for env, labels in ((single, opponent_labels(1)), (team, opponent_labels(1))):
        if env is team:
            def labels(info):
                return info["opponent_action"]  # [B, 1]: one collector, one opponent
        trainer = a2c.make_train(config, env, env.make_params(energy=6.0, max_steps=20), net, aux_target=labels)
        state, metrics = trainer.train(jax.random.PRNGKey(7))
        out.append((state.params, metrics))
    (p1, m1), (p2, m2) = out
    # The team's loss means are weighted (sum(w * x) / sum(w), every weight 1 here), the DCG's plain: the same
    # numbers summed in another order, a few float32 ulps apart, which Adam's per-element normalisation can lift to
    # ~1e-5 on a near-zero gradient entry after a few updates (seen: 3.2e-6 on one of 4,608 weights). A real
    # difference in the team path moves the parameters by the order of lr = 1e-3.
    for a, b in zip(jax.tree_util.tree_leaves(p1), jax.tree_util.tree_leaves(p2)):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-5, atol=2e-5)
    for name in ("episodes", "episode_reward_sum", "loss", "aux_accuracy"):
        np.testing.assert_allclose(np.asarray(m1[name]), np.asarray(m2[name]), rtol=1e-5, atol=1e-6)


def test_a_team_batch_has_a_row_per_collector_and_counts_an_episode_once():
    env = DCGTeam(collectors=3, **GAME)
    params = env.make_params(energy=4.0, max_steps=12)
    net = build("dcg", "vnn", history=2, state_channels=env.state_channels)
    config = _config(**PPO)
    trainer = a2c.make_train(config, env, params, net)
    state = trainer.init(jax.random.PRNGKey(1))
    assert state.obs.shape == (4, 3, 4, 4, env.observation_shape()[-1])
    # the network was initialised on rows of one collector's observation
    logits, value = net.apply(state.params, state.obs[:, 0])
    assert logits.shape == (4, 9) and value.shape == (4,)
    states, metrics = trainer.run(state, 6)
    # 4 environments x 8 steps x 6 updates; the step cap 12 ends every episode by step 12, so at least 4 x 4
    # episodes end, and an episode is counted once, not once per collector
    episodes = int(np.sum(np.asarray(metrics["episodes"])))
    assert 16 <= episodes <= 4 * 8 * 6 and episodes % 1 == 0
    assert np.all(np.isfinite(np.asarray(metrics["loss"])))
    # the mean reward of the ended episodes is a team reward: at most the items
    mean = float(np.sum(np.asarray(metrics["episode_reward_sum"]))) / episodes
    assert 0.0 <= mean <= 4.0


def test_rows_of_weight_zero_change_neither_the_loss_nor_its_gradient():
    """A disabled collector's rows (weight 0) may hold anything: the loss, its gradient and the metrics are those
    of the active rows alone (the weighted means of a2c_loss and aux_cross_entropy)."""
    net = build("dcg", "omn_conn", history=2, state_channels=3)
    rng = np.random.default_rng(0)
    obs = jnp.asarray(rng.random((6, 4, 4, 5)), jnp.float32)
    params = net.init(jax.random.PRNGKey(0), obs, jnp.zeros((6, 1, 9)))
    actions, targets = jnp.asarray([0, 3, 8, 1, 4, 2]), jnp.asarray([1, 2, 3, 4, 5, 6])
    returns = jnp.asarray([0.5, 1.0, -0.2, 2.0, 0.0, 1.5])
    weights = jnp.asarray([1.0, 1.0, 0.0, 1.0, 0.0, 1.0])
    config = _config(**PPO)
    old = jnp.log(jnp.full(6, 1 / 9))
    adv = returns - 0.3

    def loss(obs, actions, returns, targets, old, adv):
        return a2c.a2c_loss(params, net.apply, obs, jnp.zeros((6, 1, 9)), actions, returns, config, targets, old,
                            adv, weights)

    def grad(*args):
        return jax.grad(lambda p: a2c.a2c_loss(p, net.apply, args[0], jnp.zeros((6, 1, 9)), *args[1:3], config,
                                               *args[3:], weights)[0])(params)

    args = (obs, actions, returns, targets, old, adv)
    dead = np.asarray(weights) == 0
    changed = (obs.at[dead].set(7.0), actions.at[dead].set(5), returns.at[dead].set(-9.0), targets.at[dead].set(0),
               old.at[dead].set(-0.1), adv.at[dead].set(4.0))
    (l1, m1), (l2, m2) = loss(*args), loss(*changed)
    assert float(l1) == pytest.approx(float(l2), rel=1e-6)
    for k in m1:
        assert float(m1[k]) == pytest.approx(float(m2[k]), rel=1e-6, abs=1e-7), k
    for a, b in zip(jax.tree_util.tree_leaves(grad(*args)), jax.tree_util.tree_leaves(grad(*changed))):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-5, atol=1e-7)
    # and the active rows alone give the same loss as the unweighted loss of those rows
    keep = ~dead
    alone = a2c.a2c_loss(params, net.apply, obs[keep], jnp.zeros((4, 1, 9)), actions[keep], returns[keep], config,
                         targets[keep], old[keep], adv[keep])[0]
    assert float(l1) == pytest.approx(float(alone), rel=1e-5)


def test_an_update_with_every_collector_disabled_at_once_stays_finite():
    """Energy 1: a collector that leaves the base is disabled on its first step, so most rows weigh 0."""
    env = DCGTeam(collectors=2, **GAME)
    trainer = a2c.make_train(_config(**PPO), env, env.make_params(energy=1.0, max_steps=20),
                             build("dcg", "vnn", history=2, state_channels=env.state_channels))
    _, metrics = trainer.run(trainer.init(jax.random.PRNGKey(3)), 3)
    for name in ("loss", "policy_loss", "value_loss", "entropy"):
        assert np.all(np.isfinite(np.asarray(metrics[name]))), name
    assert int(np.sum(np.asarray(metrics["episodes"]))) > 0


def test_a_team_refuses_heuristics_and_a_network_that_reads_them():
    env = DCGTeam(collectors=2, **GAME)
    params = env.make_params()
    with pytest.raises(ValueError, match="heuristics"):
        a2c.make_train(_config(), env, params, build("dcg", "vnn", history=2, state_channels=3),
                       heuristics=lambda s: jnp.zeros((1, 1, 9)))
    enn = build("dcp", "enn")
    with pytest.raises(ValueError, match="reads heuristics"):
        a2c.make_train(_config(), env, params, enn)
    with pytest.raises(ValueError, match="mask: an action mask plays one agent's state, not a team of 2"):
        a2c.make_train(_config(), env, params, build("dcg", "vnn", history=2, state_channels=3),
                       mask=lambda s: jnp.ones(9, bool))


def test_init_params_start_the_run_and_must_fit_the_network():
    """A warm start (make_train's init_params) replaces the fresh initialisation, nothing else; a misfit is named."""
    env = DCGTeam(collectors=2, **GAME)
    net = build("dcg", "omn_conn", history=2, state_channels=3)
    labels = opponent_labels(2)
    params = env.make_params(energy=6.0, max_steps=20)
    fresh = a2c.make_train(_config(), env, params, net, aux_target=labels).init(jax.random.PRNGKey(0))
    start = jax.tree_util.tree_map(lambda x: x + 1.0, fresh.params)
    warm = a2c.make_train(_config(), env, params, net, aux_target=labels, init_params=start).init(
        jax.random.PRNGKey(0))
    for a, b in zip(jax.tree_util.tree_leaves(start), jax.tree_util.tree_leaves(warm.params)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    np.testing.assert_array_equal(np.asarray(warm.obs), np.asarray(fresh.obs))  # the same games
    narrow = build("dcg", "omn_conn", history=2, state_channels=2)
    other = a2c.make_train(_config(), DCG(**GAME), params, narrow, aux_target=opponent_labels(1)).init(
        jax.random.PRNGKey(0)).params
    with pytest.raises(ValueError, match="init_params: parameter .* has shape"):
        a2c.make_train(_config(), env, params, net, aux_target=labels, init_params=other)
