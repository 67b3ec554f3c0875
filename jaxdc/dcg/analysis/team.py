"""Team yardsticks of the team DCG (issue 29): copies of a one-collector network and the scripted team, k = 1..4.

The thesis' conclusion to chapter 5 asks whether several collectors can "cooperate to collect data more
efficiently under the influence of the opponent". Before any team is trained, two yardsticks answer how much
a team earns without learning to cooperate (:mod:`jaxdc.dcg.team.policies`): ``k`` copies of a shipped
one-collector network, each seeing the game as in the one-collector observation, and the scripted
``greedy_split`` team. :func:`team_game` builds the team game of a network's training setting, and
:func:`evaluate_team` plays a team policy and summarises the games: the team reward (mean, SD, SE), the
share of games cleared, and the capture rate (the share of collectors caught, and the share of games in which
at least one is). With one collector, ``copies`` plays exactly the games of
:func:`jaxdc.dcg.evaluate.evaluate_network` for the same key. :func:`evaluate_learned` is ``python -m eval.dcg
--collectors K``: a one-collector network as ``K`` copies, or a team-trained network (``train.dcg --collectors``)
in its own team.
"""

from __future__ import annotations

import math
import os
from typing import Any, Callable

import jax
import numpy as np

from jaxdc.core.rollout import run_episodes
from jaxdc.core.validate import check_int, check_positive_int
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.team import DCGTeam
from jaxdc.dcg.team.env import DCG_SETTINGS
from jaxdc.dcg.team.policies import copies, greedy_split
from jaxdc.dcg.team.state import MAX_COLLECTORS
from jaxdc.dcg.types import CAUGHT, CLEARED

#: The yardstick teams :func:`team_table` plays.
TEAMS = ("copies", "greedy_split")


def team_game(learned: learned_lib.Learned, collectors: int, teammates: bool | None = None,
              energy: float | None = None, strategies: Any = None, max_steps: int | None = None,
              **options: Any) -> tuple:
    """``(env, params)``: the team game of ``collectors`` players in ``learned``'s training setting (its grid,
    items, strategies, history, rule readings and energy), with ``energy``, ``strategies`` and ``max_steps``
    changed where given (:meth:`~jaxdc.dcg.learned.Learned.game`); ``teammates`` defaults to the observation
    ``learned`` was trained on (the teammates plane for a team-trained network, ``train.dcg --collectors``; else
    the one-collector observation that copies of a one-collector network read); ``options`` go to
    :class:`~jaxdc.dcg.team.DCGTeam`. A team-trained network plays only its own team size (``ValueError``)."""
    check_int("collectors", collectors, 1, MAX_COLLECTORS)
    if learned.collectors > 1 and collectors != learned.collectors:
        raise ValueError(f"collectors={collectors}: {learned.net_name} ({learned.source}) was trained by a team of "
                         f"{learned.collectors} collectors and plays in one of {learned.collectors}")
    game, params = learned.game(energy=energy, strategies=strategies, max_steps=max_steps)
    same = {k: getattr(game, k) for k in DCG_SETTINGS if not k.startswith("_")}
    teammates = learned.collectors > 1 if teammates is None else teammates
    env = DCGTeam(collectors=collectors, teammates=teammates, grid_size=game.grid_size, **same, **options)
    return env, params


def evaluate_team(env: DCGTeam, params: Any, policy: Callable, key: jax.Array, episodes: int,
                  lanes: int | None = 512) -> dict:
    """Play ``episodes`` games of the team ``policy`` (``policy(key, obs [k, ...], state) -> [k]``) and summarise
    them: ``reward`` (mean, sd, se), ``cleared`` (share of games), ``caught_collectors`` (share of collectors
    caught), ``any_caught`` (share of games with a capture), ``per_strategy`` team reward means."""
    if not isinstance(env, DCGTeam):
        raise TypeError(f"env must be a jaxdc.dcg.team.DCGTeam, got {type(env).__name__}")
    episodes = check_positive_int("episodes", episodes)
    final = jax.jit(lambda k: run_episodes(env, params, policy, k, episodes, lanes))(key)
    reward = np.asarray(final.ep_reward, np.float64)
    caught = np.asarray(final.collector_outcome) == CAUGHT
    sd = float(reward.std(ddof=1)) if episodes > 1 else None
    strategy = np.asarray(final.strategy)[:, 0]
    return {
        "collectors": env.collectors, "episodes": episodes,
        "reward": {"mean": float(reward.mean()), "sd": sd, "se": None if sd is None else sd / math.sqrt(episodes)},
        "cleared": float(np.mean(np.asarray(final.outcome) == CLEARED)),
        "caught_collectors": float(caught.mean()),
        "any_caught": float(caught.any(axis=1).mean()),
        "per_strategy": {name: float(reward[strategy == i].mean()) if np.any(strategy == i) else None
                         for i, name in enumerate(env.strategies)},
    }


def evaluate_learned(learned: learned_lib.Learned, collectors: int | None = None, episodes: int = 10_000,
                     seed: int = 0, greedy: bool = False, energy: float | None = None, strategies: Any = None,
                     max_steps: int | None = None) -> dict:
    """``learned`` as a team (``python -m eval.dcg --collectors K``): a one-collector network as ``collectors``
    copies (:func:`~jaxdc.dcg.team.policies.copies`, default one), a team-trained network in its own team
    (``collectors`` ``None`` or its size), on ``episodes`` games of ``PRNGKey(seed)`` in its training setting
    with the given changes. The summary of :func:`evaluate_team`, with what was played."""
    k = learned.collectors if collectors is None else check_int("collectors", collectors, 1, MAX_COLLECTORS)
    env, params = team_game(learned, k, energy=energy, strategies=strategies, max_steps=max_steps)
    out = evaluate_team(env, params, copies(learned.policy(greedy), k), jax.random.PRNGKey(seed), episodes)
    setting = learned.setting()
    source = os.path.relpath(learned.source) if os.path.exists(learned.source) else learned.source
    return {"net": learned.net_name, "source": source,
            "team": "copies" if learned.collectors == 1 else "trained", "seed": seed, "greedy": bool(greedy),
            "setting": {"energy": setting["energy"] if energy is None else energy,
                        "strategies": list(env.strategies),
                        "max_steps": setting["max_steps"] if max_steps is None else max_steps},
            **out}


def team_table(learned: learned_lib.Learned, collectors: tuple[int, ...] = (1, 2, 3, 4), episodes: int = 10_000,
               seed: int = 1, greedy: bool = False) -> dict:
    """The yardsticks of :data:`TEAMS` for each team size in ``collectors``, on the same games per size (one key)."""
    rows = []
    for k in collectors:
        check_int("collectors", k, 1, MAX_COLLECTORS)
        env, params = team_game(learned, k)
        key = jax.random.PRNGKey(seed)
        rows.append({"collectors": k, "copies": evaluate_team(env, params, copies(learned.policy(greedy), k),
                                                              key, episodes),
                     "greedy_split": evaluate_team(env, params, greedy_split(env.grid_size, k), key, episodes)})
    return {"net": learned.net_name, "source": learned.source, "episodes": episodes, "seed": seed,
            "greedy": bool(greedy), "rows": rows}
