"""Batched evaluation of DCP policies and the episode statistics of Tables 4.1-4.10.

:func:`evaluate_heuristic` plays many episodes of a heuristic policy (by name),
:func:`evaluate_learned` those of a trained network (ENN, EQN, linear, CNN),
both through the same batched :func:`jaxdc.core.rollout.run_episodes`, and :func:`summarize` turns the
final states into the thesis' columns: reward, energy and reward per energy
(RPE), each as mean and SD, plus how the episodes ended.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import numpy as np

from jaxdc.core.paths import safest_paths
from jaxdc.core.rollout import run_episodes
from jaxdc.core.stats import RPE_ZERO, episode_summary  # noqa: F401  (RPE_ZERO: the public name)
from jaxdc.core.validate import check_choice, check_positive_int
from jaxdc.dcp import instances, masks, navigators
from jaxdc.dcp.env import DCP, OUTCOMES, EnvParams
from jaxdc.dcp.planners import PlannerConfig


def heuristic_policy(name: str, table, cfg: PlannerConfig = PlannerConfig(), max_energy=None):
    """``policy(key, obs, state)`` for a navigator or planner name (see :data:`navigators.POLICIES`; Safe-Budget
    also reads the maximum energy)."""
    check_choice("policy", name, navigators.POLICIES)

    def policy(key, obs, state):
        return navigators.policy_action(name, state, table, cfg, max_energy)

    return policy


@functools.partial(jax.jit, static_argnames=("env", "name", "cfg", "episodes", "path_risk"))
def _run_heuristic(env, params, key, name, cfg, episodes, path_risk):
    table = safest_paths(params.risk, path_risk)
    return run_episodes(env, params, heuristic_policy(name, table, cfg, params.max_energy), key, episodes)


@functools.partial(jax.jit, static_argnames=("env", "name", "cfg", "episodes"))
def _run_instance_heuristic(env, params, key, name, cfg, episodes):
    return run_episodes(env, params, instances.heuristic_policy(name, params, cfg), key, episodes)


def evaluate_heuristic(
    env: DCP,
    params: EnvParams,
    name: str,
    key,
    episodes: int = 10_000,
    cfg: PlannerConfig = PlannerConfig(),
    path_risk: str = "departed",
):
    """Final states of ``episodes`` episodes of heuristic policy ``name`` (jitted, batched); with per-episode maps
    (``params.maps``) each episode plans on its own map's table."""
    check_choice("policy", name, navigators.POLICIES)
    env.check_param_values(env.check_params(params))
    if params.maps is not None:
        return _run_instance_heuristic(env, params, key, name, cfg, check_positive_int("episodes", episodes))
    return _run_heuristic(env, params, key, name, cfg, check_positive_int("episodes", episodes), path_risk)


@functools.partial(jax.jit, static_argnames=("env", "net", "net_name", "episodes", "greedy", "cfg", "path_risk",
                                             "mask"))
def _run_learned(env, params, key, net, net_name, net_params, episodes, greedy, epsilon, cfg, path_risk, mask):
    from jaxdc.dcp.learned import Learned, heuristic_rows

    rows = heuristic_rows(net)
    if params.maps is None:
        heuristics = navigators.batched_heuristics(params, safest_paths(params.risk, path_risk), cfg, rows)
    else:  # per-episode maps: each episode's own table (computed with the default path_risk)
        heuristics = instances.batched_heuristics(params, cfg, rows)
    learned = Learned(net_name, net, net_params, {}, "")
    return run_episodes(env, params, learned.policy(heuristics, greedy, epsilon, masks.make_mask(mask, env)), key,
                        episodes)


def evaluate_learned(
    env: DCP,
    params: EnvParams,
    learned,
    key,
    episodes: int = 10_000,
    greedy: bool = False,
    epsilon: float | None = None,
    cfg: PlannerConfig = PlannerConfig(),
    path_risk: str = "departed",
    mask: str = "none",
):
    """Final states of ``episodes`` episodes of a learned network (jitted, batched like the navigators).

    ``learned`` is a :class:`jaxdc.dcp.learned.Learned`. Actor-critics sample
    from ``pi`` (section 4.5) unless ``greedy``; EQN is epsilon-greedy with
    ``epsilon`` (default 0.05, section 4.5.5). The network sees the ten ENN
    heuristics of section 4.4.3 computed on ``params``' risk map (and Safe-Budget, if it reads eleven rows).
    ``mask`` names an action mask of
    :data:`jaxdc.core.masks.MASKS` (``"none"``: the thesis' policy). Raises a
    ``ValueError`` if the network's parameters do not fit ``env``'s grid.
    """
    from jaxdc.dcp.learned import EQN_EPSILON, check_params

    env.check_param_values(env.check_params(params))
    epsilon = EQN_EPSILON if epsilon is None else float(epsilon)
    if not 0.0 <= epsilon <= 1.0:
        raise ValueError(f"epsilon must be in [0, 1], got {epsilon!r}")
    observation = getattr(learned, "observation", "thesis")
    if env.observation != observation:
        raise ValueError(f"{learned.source} reads the {observation!r} observation but the environment gives "
                         f"{env.observation!r}; build it with DCP(..., observation={observation!r})")
    net_params = check_params(learned.net_name, learned.net, learned.params, env.grid_size, learned.source,
                              observation)
    episodes = check_positive_int("episodes", episodes)
    check_choice("mask", mask, masks.MASKS)
    return _run_learned(env, params, key, learned.net, learned.net_name, net_params, episodes,
                        bool(greedy), jax.numpy.float32(epsilon), cfg, path_risk, mask)


class OptimalEvaluation(NamedTuple):
    """The exact single-item optimum played (section 4.5.4): its episodes' final states and its expected reward."""

    final: object  # the final EnvState of every episode, batched
    expected_optimum: float  # the optimal expected reward over the start distribution


def evaluate_optimal(env: DCP, params: EnvParams, key, episodes: int = 10_000) -> OptimalEvaluation:
    """Final states of the exact optimal policy of the single-item DCP (``total_reward=1``).

    Solves the MDP by value iteration (:mod:`jaxdc.dcp.exact.optimal`) and plays it
    like any other policy.
    """
    from jaxdc.dcp.exact.optimal import expected_optimum, optimal_policy, solve_single_item

    if env.total_reward != 1:
        raise ValueError(f"policy 'optimal' needs total_reward=1 (the single-item setting), got {env.total_reward}")
    env.check_param_values(env.check_params(params))
    sol = solve_single_item(
        np.asarray(params.risk), float(params.max_energy), float(params.init_energy), grid_size=env.grid_size
    )
    episodes = check_positive_int("episodes", episodes)
    final = jax.jit(lambda k: run_episodes(env, params, optimal_policy(sol), k, episodes))(key)
    return OptimalEvaluation(final, expected_optimum(sol, env.items_on_base, env.start))


def summarize(final_states, rpe_zero: str = "exclude") -> dict:
    """Mean/SD of reward, energy, RPE and steps over episodes, plus outcome counts.

    RPE is the mean of per-episode ``reward / energy`` (footnote 4: "Reward
    per energy is also an average over 10,000 runs"). Episodes that used no
    energy are left out (``rpe_zero="exclude"``) or count as RPE 0
    (``"zero"``). SDs are population SDs (``ddof=0``). A statistic with no
    sample (RPE when no episode used energy) is ``{"mean": None, "sd": None,
    "undefined": reason}`` (:func:`jaxdc.core.stats.mean_sd`), never NaN.
    """
    return episode_summary(final_states, OUTCOMES, rpe_zero)
