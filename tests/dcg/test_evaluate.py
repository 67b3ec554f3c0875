"""jaxdc.dcg.evaluate (section 5.5 statistics), jaxdc.core.stats and jaxdc.core.trajectory on tiny games."""

from __future__ import annotations

import types

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import grid
from jaxdc.core.stats import episode_summary
from jaxdc.core.trajectory import play_episode
from jaxdc.dcg import evaluate as ev
from jaxdc.dcg.env import DCG, OUTCOMES, RUNNING
from jaxdc.dcg.learned import init_params, make_network
from tests.support.states import make_game

TINY = dict(grid_size=3, total_reward=3, history=2)


@pytest.fixture(scope="module")
def tiny():
    env = DCG(**TINY)
    params = env.make_params(energy=6.0, max_steps=12)
    net = make_network("omn_conn", 2)
    net_params = init_params(net, 3, 2, jax.random.PRNGKey(3))
    final = ev.evaluate_network(env, params, net, net_params, jax.random.PRNGKey(0), episodes=48)
    return env, params, net, net_params, final


def test_per_strategy_breakdown_adds_up_to_the_total(tiny):
    env, *_, final = tiny
    s = ev.summarize(final, env.strategies)
    per = s["per_strategy"]
    assert list(per) == list(env.strategies)
    assert sum(p["episodes"] for p in per.values()) == s["episodes"] == 48
    for col in ("reward", "energy", "steps"):
        weighted = sum(p["episodes"] * p[col]["mean"] for p in per.values() if p["episodes"]) / s["episodes"]
        assert weighted == pytest.approx(s[col]["mean"], rel=1e-12)
    for outcome in s["outcomes"]:
        assert sum(p["outcomes"][outcome] for p in per.values()) == s["outcomes"][outcome]
    # pooled accuracy = per-strategy accuracies weighted by their predicted steps
    predicted = np.asarray(final.predicted)
    strategy = np.asarray(final.game.strategy)
    weights = [predicted[strategy == i].sum() for i in range(len(env.strategies))]
    pooled = sum(w * p["opponent_accuracy"] for w, p in zip(weights, per.values()) if w) / sum(weights)
    assert pooled == pytest.approx(s["opponent_accuracy"], rel=1e-12)


def test_an_aux_network_is_scored_on_every_step(tiny):
    *_, final = tiny
    final = jax.device_get(final)
    # one prediction per step played: predicted steps = episode length
    np.testing.assert_array_equal(np.asarray(final.predicted), np.asarray(final.game.time))
    assert np.all(np.asarray(final.correct) <= np.asarray(final.predicted))
    assert np.all(np.asarray(final.game.outcome) != RUNNING)
    assert np.all(np.asarray(final.game.time) <= 12)


def test_same_seed_same_numbers_other_seed_other_games(tiny):
    env, params, net, net_params, final = tiny
    again = ev.evaluate_network(env, params, net, net_params, jax.random.PRNGKey(0), episodes=48)
    for a, b in zip(jax.tree_util.tree_leaves(final), jax.tree_util.tree_leaves(again)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    other = ev.evaluate_network(env, params, net, net_params, jax.random.PRNGKey(1), episodes=48)
    assert not np.array_equal(np.asarray(other.game.ep_reward), np.asarray(final.game.ep_reward)) or \
        not np.array_equal(np.asarray(other.game.time), np.asarray(final.game.time))


def test_accuracy_counts_a_hand_made_step():
    """The restricted opponent at (0, 2) chasing the collector at (2, 2) moves down (o_t = 2)."""
    env = DCG(grid_size=3, total_reward=1, history=2, strategies=("restricted",))
    params = env.make_params(energy=6.0, max_steps=12)
    game = make_game(env, pos=(2, 2), opp=(0, 2), strategy="restricted", items={(1, 0): 1.0})
    scored = ev.Scored(env)
    state = ev.ScoredState(game, jnp.int32(5), jnp.int32(3))
    down = grid.ACTIONS.index("down")
    key = jax.random.PRNGKey(0)
    _, _, _, _, _, info = env.step_env(key, game, jnp.int32(0), params)
    assert int(info["opponent_action"]) == down
    for guess, predicted, correct in ((down, 6, 4), (grid.ACTIONS.index("up"), 6, 3), (-1, 5, 3)):
        _, after, *_ = scored.step_env(key, state, (jnp.int32(0), jnp.int32(guess)), params)
        assert (int(after.predicted), int(after.correct)) == (predicted, correct), guess
    assert ev.accuracy(np.array([3, 1]), np.array([4, 2])) == pytest.approx(4 / 6)
    assert ev.accuracy(np.array([0, 0]), np.array([0, 0])) is None


def test_a_network_without_head_has_no_accuracy():
    env = DCG(**TINY)
    params = env.make_params(energy=6.0, max_steps=12)

    def stay(key, obs, state):
        return jnp.int32(0)

    final = ev.evaluate_policy(env, params, stay, jax.random.PRNGKey(0), episodes=8)
    s = ev.summarize(final, env.strategies)
    assert s["opponent_accuracy"] is None
    assert all(p["opponent_accuracy"] is None for p in s["per_strategy"].values())
    assert s["energy"]["mean"] == 0.0  # staying in the base uses no energy ...
    assert s["rpe"]["mean"] is None  # ... so every game is left out of the RPE, which is undefined
    assert s["rpe"]["undefined"] == "no episode consumed energy"
    assert ev.summarize(final, env.strategies, rpe_zero="zero")["rpe"]["mean"] == 0.0
    with pytest.raises(ValueError, match="episodes"):
        ev.evaluate_policy(env, params, stay, jax.random.PRNGKey(0), episodes=0)


def test_episode_summary_is_the_dcp_summary():
    """One statistics function for both problems: the DCP's summarize gives the same dict."""
    from jaxdc.dcp.env import OUTCOMES as DCP_OUTCOMES
    from jaxdc.dcp.evaluate import summarize as dcp_summarize

    rng = np.random.default_rng(0)
    final = types.SimpleNamespace(ep_reward=rng.integers(0, 5, 50).astype(np.float32),
                                  ep_energy=rng.integers(0, 4, 50), outcome=rng.integers(1, 4, 50),
                                  time=rng.integers(1, 20, 50))
    for rpe_zero in ("exclude", "zero"):
        assert episode_summary(final, DCP_OUTCOMES, rpe_zero) == dcp_summarize(final, rpe_zero)
    mask = final.outcome == 2
    sub = episode_summary(final, OUTCOMES, mask=mask)
    assert sub["episodes"] == int(mask.sum())
    assert sub["reward"]["mean"] == pytest.approx(float(final.ep_reward[mask].mean()))


def test_relative_increase():
    assert ev.relative_increase(1.19, 1.0) == pytest.approx(19.0)
    assert ev.relative_increase(1.0, 0.0) is None
    assert ev.relative_increase(None, 1.0) is None


def test_play_episode_returns_every_state_of_one_game():
    env = DCG(**TINY)
    params = env.make_params(energy=6.0, max_steps=12)

    def right(key, obs, state):
        return jnp.int32(grid.ACTIONS.index("right"))

    states = play_episode(env, params, right, jax.random.PRNGKey(4), 12)
    times = [int(s.time) for s in states]
    assert times == list(range(len(states)))
    assert int(states[0].outcome) == RUNNING and all(int(s.outcome) == RUNNING for s in states[:-1])
    assert int(states[-1].outcome) != RUNNING  # ends at the first terminal or truncated step
    for t, s in enumerate(states[:-1]):  # moving right along the top edge until the game ends
        assert tuple(int(x) for x in s.pos) == (0, min(t, 2))
    again = play_episode(env, params, right, jax.random.PRNGKey(4), 12)
    assert [int(s.opponent.pos.sum()) for s in again] == [int(s.opponent.pos.sum()) for s in states]
    with pytest.raises(ValueError, match="max_steps"):
        play_episode(env, params, right, jax.random.PRNGKey(4), 0)


def test_summary_is_a_typed_record_whose_json_is_the_old_dict():
    """summarize's JSON is the Summary's to_json, key for key and in order; from_dict reads it back."""
    import json

    from jaxdc.dcg.summary import MeanSD, Summary

    rng = np.random.default_rng(1)
    n = 40
    game = types.SimpleNamespace(ep_reward=rng.integers(0, 5, n).astype(np.float32),
                                 ep_energy=rng.integers(0, 4, n), outcome=rng.integers(1, 4, n),
                                 time=rng.integers(1, 20, n), strategy=rng.integers(0, 3, n))
    final = types.SimpleNamespace(game=game, predicted=rng.integers(0, 9, n), correct=rng.integers(0, 5, n))
    strategies = ("patrol", "restricted", "empty")
    final.game.strategy[final.game.strategy == 2] = 1  # no games of the last strategy: undefined statistics
    s = ev.summary(final, strategies)
    assert isinstance(s, Summary) and isinstance(s.reward, MeanSD) and s.episodes == n
    assert s.per_strategy["empty"].reward == MeanSD(None, None, "no episodes")
    old = episode_summary(game, OUTCOMES)
    old["opponent_accuracy"] = ev.accuracy(final.correct, final.predicted)
    old["per_strategy"] = {}
    for i, name in enumerate(strategies):
        mask = game.strategy == i
        old["per_strategy"][name] = {**episode_summary(game, OUTCOMES, mask=mask),
                                     "opponent_accuracy": ev.accuracy(final.correct[mask], final.predicted[mask])}
    assert json.dumps(ev.summarize(final, strategies)) == json.dumps(old) == json.dumps(s.to_json())
    assert Summary.from_dict(json.loads(json.dumps(old))) == s
    bare = Summary.from_dict({"reward": {"mean": 1.0, "sd": 0.5}})  # a hand-made record: the rest undefined
    assert bare.energy == MeanSD(None, None) and bare.episodes == 0 and bare.per_strategy is None
