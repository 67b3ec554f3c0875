"""Batched evaluation of DCG collectors: the statistics of section 5.5 (Figs. 5.6-5.19).

:func:`evaluate_policy` plays many games of a ``policy(key, obs, state) ->
action`` at once (:func:`jaxdc.core.rollout.run_episodes`, jitted) and
:func:`summary` turns them into the thesis' numbers (a :class:`~jaxdc.dcg.summary.Summary`): the *episode reward*
and the *reward per energy* (RPE, as for the DCP: the mean of per-game
``reward / energy``), each as mean and SD over the games (section 5.5.3: "We
run experiments in 10,000 randomly generated environments"), how the games
ended, the same numbers for each opponent strategy (``info["strategy"]``),
and, for a network that predicts the opponent's action (EMNN's and OMN's
``pi^o``, sections 5.4.4-5.4.5), its accuracy: the fraction of steps where
the predicted action is the opponent's action ``o_t`` of that step (the
"accuracy in predicting opponent actions" of section 5.5.3: about 75% for
EMNN and over 98% for OMN).

The accuracy is counted inside the game: :class:`Scored` wraps the
environment so that its state also counts, per game, the steps and the
correctly predicted steps. The policy returns ``(action, predicted o_t)``, so
the network runs once per step for both.
"""

from __future__ import annotations

import functools
import math
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxdc.core.masks import MASKS, make_mask
from jaxdc.core.rollout import run_episodes
from jaxdc.core.stats import RPE_ZERO, episode_summary
from jaxdc.core.validate import check_choice, check_positive_int
from jaxdc.dcg.env import DCG, OUTCOMES, EnvParams, EnvState
from jaxdc.dcg.summary import MeanSD, Summary

#: Default number of games (section 5.5.3).
EPISODES = 10_000
#: Games stepped at once by default: fewer lanes than games lets finished lanes start new games
#: instead of idling until the longest game ends (never changes the numbers).
LANES = 512


@struct.dataclass
class ScoredState:
    """A game state plus the counts of the opponent-action prediction over the game so far."""

    game: EnvState
    predicted: jax.Array  # int32 steps with a prediction of o_t
    correct: jax.Array  # int32 of those, steps where the prediction equals o_t

    @property
    def time(self):
        return self.game.time


class Scored:
    """A :class:`~jaxdc.dcg.env.DCG` whose actions are ``(action, predicted o_t)`` (``-1``: no prediction).

    ``step_env`` plays ``action`` and counts whether the prediction equals the
    opponent's action ``info["opponent_action"]`` of the same step (the
    opponent moves first, section 5.3; the network predicts it from the
    observation before the step, as it is trained to, Eq. 5.1).
    """

    def __init__(self, env: DCG):
        self.env = env

    def __eq__(self, other):
        return type(other) is Scored and other.env == self.env

    def __hash__(self):
        return hash(("Scored", self.env))

    def check_params(self, params: EnvParams) -> EnvParams:
        """The game's check (:meth:`jaxdc.core.env.Environment.check_params`): params of another grid are refused."""
        return self.env.check_params(params)

    def reset_env(self, key, params: EnvParams):
        obs, state = self.env.reset_env(key, params)
        return obs, ScoredState(state, jnp.int32(0), jnp.int32(0))

    def step_env(self, key, state: ScoredState, action, params: EnvParams):
        action, prediction = action
        obs, game, reward, term, trunc, info = self.env.step_env(key, state.game, action, params)
        has = prediction >= 0
        hit = has & (prediction == info["opponent_action"])
        scored = ScoredState(game, state.predicted + has.astype(jnp.int32), state.correct + hit.astype(jnp.int32))
        return obs, scored, reward, term, trunc, info


def with_prediction(policy: Callable, predict: Callable | None = None) -> Callable:
    """``policy(key, obs, state) -> (action, predicted o_t)`` for :class:`Scored`.

    ``predict(obs) -> int`` is the predicted opponent action (the argmax of an
    auxiliary head, see :func:`aux_predictor`); without one, ``-1``.
    """

    def scored(key, obs, state):
        guess = jnp.int32(-1) if predict is None else jnp.asarray(predict(obs), jnp.int32)
        return policy(key, obs, state.game), guess

    return scored


def aux_predictor(net, params) -> Callable | None:
    """``obs -> argmax pi^o(s, h)`` of a network with an opponent-action head (``net.has_aux``), else ``None``.

    Inside one jitted step XLA computes the network once for the action and
    the prediction (common subexpressions of the same inputs are merged).
    """
    if not getattr(net, "has_aux", False):
        return None
    dummy = jnp.zeros((1, 1, 9), jnp.float32)  # networks without heuristics ignore them

    def predict(obs):
        out = net.apply(params, obs[None], dummy)
        return jnp.argmax(out[2][0]).astype(jnp.int32)

    return predict


def evaluate_policy(env: DCG, params: EnvParams, policy: Callable, key, episodes: int = EPISODES,
                    predict: Callable | None = None, lanes: int | None = LANES) -> ScoredState:
    """Final states of ``episodes`` games of ``policy`` (jitted, batched), with the prediction counts.

    ``policy(key, obs, state) -> action`` (e.g. :func:`jaxdc.agents.a2c.make_policy`);
    ``predict(obs) -> o_t`` optionally predicts the opponent's action (see
    :func:`aux_predictor`). The same ``key`` gives the same numbers, whatever
    ``lanes``.
    """
    if not isinstance(env, DCG):
        raise TypeError(f"env must be a jaxdc.dcg.env.DCG, got {type(env).__name__}")
    env.check_param_values(env.check_params(params))
    episodes = check_positive_int("episodes", episodes)
    scored = Scored(env)
    play = with_prediction(policy, predict)
    return jax.jit(lambda k: run_episodes(scored, params, play, k, episodes, lanes))(key)


@functools.partial(jax.jit, static_argnames=("env", "net", "greedy", "episodes", "lanes", "mask"))
def _run_network(env, params, net, net_params, key, greedy, episodes, lanes, mask):
    from jaxdc.agents.a2c import make_policy

    policy = make_policy(net, net_params, None, greedy=greedy, mask=make_mask(mask, env.grid_size))
    play = with_prediction(policy, aux_predictor(net, net_params))
    return run_episodes(Scored(env), params, play, key, episodes, lanes)


def evaluate_network(env: DCG, params: EnvParams, net, net_params, key, episodes: int = EPISODES,
                     greedy: bool = False, lanes: int | None = LANES, mask: str = "none") -> ScoredState:
    """:func:`evaluate_policy` of a DCG network (section 5.4) with its opponent-action accuracy when it has a head.

    The collector samples from ``pi`` (section 5.5.1: "The collector's policy
    is stochastic"), or takes its argmax if ``greedy``; ``mask`` (one of
    :data:`jaxdc.core.masks.MASKS`; beyond the thesis) restricts it to the
    actions that keep its energy the way home (or to an item). Compiled once per
    environment configuration and network; energies, step caps and parameters
    of the same shapes reuse the compiled code.
    """
    if not isinstance(env, DCG):
        raise TypeError(f"env must be a jaxdc.dcg.env.DCG, got {type(env).__name__}")
    env.check_param_values(env.check_params(params))
    episodes = check_positive_int("episodes", episodes)
    check_choice("mask", mask, MASKS)
    return _run_network(env, params, net, net_params, key, bool(greedy), episodes, lanes, mask)


def accuracy(correct, predicted) -> float | None:
    """``sum(correct) / sum(predicted)``: the fraction of predicted steps where the prediction was ``o_t``.

    ``None`` when nothing was predicted (a network without an opponent-action head).
    """
    total = int(np.sum(predicted))
    return None if total == 0 else float(np.sum(correct)) / total


def summary(final: ScoredState, strategies, rpe_zero: str = "exclude") -> Summary:
    """The section-5.5 statistics of :func:`evaluate_policy`'s result, as a :class:`~jaxdc.dcg.summary.Summary`.

    The fields of :func:`jaxdc.core.stats.episode_summary` (``reward``,
    ``energy``, ``rpe``, ``steps``: mean and SD; ``episodes``; ``outcomes``),
    ``opponent_accuracy`` (float or ``None``) and ``per_strategy``: the same
    fields for the games of each strategy in ``strategies`` (the env's
    strategy names; ``final.game.strategy`` indexes them). Weighted by their
    ``episodes``, the per-strategy means add up to the total.
    """
    if rpe_zero not in RPE_ZERO:
        raise ValueError(f"rpe_zero must be one of {RPE_ZERO}, got {rpe_zero!r}")
    final = jax.device_get(final)
    strategy = np.asarray(final.game.strategy)
    predicted, correct = np.asarray(final.predicted), np.asarray(final.correct)

    def games(mask=None, per_strategy=None):
        s = episode_summary(final.game, OUTCOMES, rpe_zero, mask)
        acc = accuracy(correct, predicted) if mask is None else accuracy(correct[mask], predicted[mask])
        return Summary(MeanSD.from_dict(s["reward"]), MeanSD.from_dict(s["energy"]), MeanSD.from_dict(s["rpe"]),
                       s["episodes"], s["outcomes"], MeanSD.from_dict(s["steps"]), acc, per_strategy)

    return games(per_strategy={name: games(strategy == i) for i, name in enumerate(strategies)})


def summarize(final: ScoredState, strategies, rpe_zero: str = "exclude") -> dict:
    """:func:`summary` as the JSON object the result files store (:meth:`~jaxdc.dcg.summary.Summary.to_json`):
    ``{"reward": {"mean", "sd"}, ..., "opponent_accuracy", "per_strategy": {name: {...}}}``."""
    return summary(final, strategies, rpe_zero).to_json()


def relative_increase(value: float | None, baseline: float | None) -> float | None:
    """``100 * (value / baseline - 1)``: the "% more reward than VNN" of section 5.5.3; ``None`` (undefined) for a
    0 baseline or a missing or NaN value."""
    if value is None or baseline is None or baseline == 0 or math.isnan(baseline) or math.isnan(value):
        return None
    return 100.0 * (value / baseline - 1.0)
