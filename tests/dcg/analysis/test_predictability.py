"""The ceiling of opponent-action prediction (jaxdc.dcg.analysis.predictability): labels aligned, Bayes predictor
sound."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.dcg import DCG, DOUBLE_BLIND_STRATEGIES
from jaxdc.dcg.analysis.predictability import ceiling, record, window_predict, windows

K = 3  # a short history keeps the enumeration small


def _random_policy(key, obs, state):
    return jax.random.randint(key, (), 0, 9).astype(jnp.int32)


@pytest.fixture(scope="module")
def games():
    env = DCG(grid_size=3, total_reward=3, strategies=DOUBLE_BLIND_STRATEGIES, history=K)
    params = env.make_params(energy=6.0)
    return env, params, record(env, params, _random_policy, jax.random.PRNGKey(0), num_envs=8, steps=40)


def test_labels_are_the_action_of_the_observed_state(games):
    """Some opponent state consistent with every frame of (s_t, h_t) takes exactly o_t; a label taken one
    step late (or early) is not explained on many steps."""
    env, params, rec = games
    res = ceiling(env, params, rec, chunk=64)
    assert res["steps"] == 8 * (40 - K)
    assert res["label_consistent"] == 1.0
    # the opponent stays whenever it is hidden (double-blind: the collector is in the fog), and hiding
    # reveals the strategy: predicted on every step
    assert res["per_strategy"]["double_blind"]["accuracy"] == 1.0
    assert 0.5 < res["accuracy"] <= 1.0 and res["deterministic"] <= res["accuracy"]
    frames, label, _, time = windows(rec, K)
    out = window_predict(env, params, frames, chunk=64)
    shifted = np.roll(label, 8)  # rows are (step, game): the label of the previous step of the same game
    same_episode = np.roll(time, 8) == time - 1
    late = out["possible"][np.arange(label.size), shifted][same_episode & (shifted != label)]
    assert late.size > 20 and late.mean() < 0.5


def test_windows_mark_the_frames_before_the_reset(games):
    env, _, rec = games
    frames, label, strategy, time = windows(rec, K)
    np.testing.assert_array_equal(frames["exists"].sum(1), np.minimum(time, K) + 1)
    np.testing.assert_array_equal(frames["pos"][:, -1], rec.pos[K:].reshape(-1, 2))
    np.testing.assert_array_equal(label, rec.label[K:].reshape(-1))


def test_supervised_omn_learns_a_single_chaser():
    """OMN alone on a fixed collector's games: against one restricted chaser on 3 x 3 it must beat the
    share of its most frequent action."""
    from jaxdc.dcg.analysis.predictability import supervised_omn
    from jaxdc.nets import make_dcg_net

    env = DCG(grid_size=3, total_reward=3, strategies=("restricted",), history=2)
    params = env.make_params(energy=6.0)
    net = make_dcg_net("vnn", 0)
    net_params = net.init(jax.random.PRNGKey(1), jnp.zeros((1, 3, 3, 2)))
    rows = supervised_omn(env, params, net, net_params, jax.random.PRNGKey(2), lr=3e-3, updates=100,
                          num_envs=8, t_max=8, evals=2, eval_envs=16, eval_steps=16)
    assert [r["updates"] for r in rows] == [50, 100]
    rec = record(env, params, lambda k, o, s: jax.random.randint(k, (), 0, 9), jax.random.PRNGKey(3), 16, 16)
    majority = np.bincount(rec.label.ravel(), minlength=9).max() / rec.label.size
    assert rows[-1]["accuracy"] > majority + 0.1, (rows, majority)
