"""Synchronous n-step Q-learning for EQN (jaxdc.agents.nstep_q)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.agents.nstep_q import QConfig, epsilon_greedy, make_q_policy, make_train
from jaxdc.core.paths import safest_paths
from jaxdc.core.rollout import run_episodes
from jaxdc.dcp.env import DCP
from jaxdc.dcp.evaluate import summarize
from jaxdc.dcp.navigators import batched_heuristics
from jaxdc.nets import EQN

ENV = DCP(grid_size=4, total_reward=6)
PARAMS = ENV.make_params("low", (4.0, 8.0), max_steps=100)
HEUR = batched_heuristics(PARAMS, safest_paths(PARAMS.risk))


def test_epsilon_greedy():
    q = jnp.tile(jnp.arange(9.0), (4000, 1))
    keys = jax.random.PRNGKey(0)
    assert np.all(np.asarray(epsilon_greedy(keys, q, 0.0)) == 8)
    a = np.asarray(epsilon_greedy(keys, q, 1.0))
    counts = np.bincount(a, minlength=9)
    assert counts.min() > 4000 / 9 * 0.75  # uniform over the 9 actions
    share = np.mean(np.asarray(epsilon_greedy(keys, q, 0.05)) != 8)
    assert 0.02 < share < 0.08  # 0.05 * 8/9 = 0.044


def test_epsilon_schedule_and_target_period():
    cfg = QConfig(total_steps=100 * 512, eps_start=1.0, eps_end=0.1, eps_fraction=0.5, target_every=5 * 512)
    assert float(cfg.epsilon(0)) == pytest.approx(1.0)
    assert float(cfg.epsilon(25)) == pytest.approx(0.55)
    assert float(cfg.epsilon(50)) == pytest.approx(0.1) and float(cfg.epsilon(99)) == pytest.approx(0.1)
    assert cfg.target_period == 5
    for bad, match in (({"eps_end": 1.5}, "eps_end"), ({"eps_fraction": 0.0}, "eps_fraction"),
                       ({"target_every": 0}, "target_every"), ({"lr": 0.0}, "lr")):
        with pytest.raises(ValueError, match=match):
            QConfig(**bad)


def test_target_network_copies_every_period_and_eqn_learns():
    net = EQN()
    cfg = QConfig(total_steps=8192, num_envs=16, t_max=8, lr=1e-3, target_every=4 * 128)
    trainer = make_train(cfg, ENV, PARAMS, net, HEUR)
    evaluate = jax.jit(lambda p, k: run_episodes(ENV, PARAMS, make_q_policy(net, p, HEUR), k, 500))
    state = trainer.init(jax.random.PRNGKey(0))
    before = summarize(evaluate(state.params, jax.random.PRNGKey(7)))["reward"]["mean"]
    leaf = lambda tree: np.asarray(jax.tree_util.tree_leaves(tree)[0])  # noqa: E731
    for i in range(1, cfg.num_updates + 1):
        state, metrics = trainer.update(state)
        if i in (3, 4):
            same = np.array_equal(leaf(state.params), leaf(state.target_params))
            assert same == (i == 4), i  # copied at update 4, not before
    assert np.isfinite(float(metrics["loss"])) and float(metrics["epsilon"]) == pytest.approx(0.05)
    after = summarize(evaluate(state.params, jax.random.PRNGKey(7)))["reward"]["mean"]
    assert after > before + 1.0, (before, after)


def test_make_train_rejects_an_a2c_config():
    from jaxdc.agents.a2c import A2CConfig

    with pytest.raises(TypeError, match="QConfig"):
        make_train(A2CConfig(), ENV, PARAMS, EQN())
