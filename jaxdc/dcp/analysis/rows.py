"""The rows of a DCP results table (section 4.5): each policy played in one setting and summarized.

A row is a navigator or planner (Algorithms 7-9), the exact single-item
optimum (section 4.5.4) or a learned network (sections 4.4.3, 4.5), played
for the same episodes from the same key and summarized into the thesis'
columns (:func:`jaxdc.dcp.evaluate.summarize`) plus the wall time of the row.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable

import jax

from jaxdc.core import memory
from jaxdc.dcp.analysis.setting import EnvOptions, Setting, make_env
from jaxdc.dcp.evaluate import evaluate_heuristic, evaluate_learned, evaluate_optimal, summarize
from jaxdc.dcp.learned import EQN_EPSILON, NETS
from jaxdc.dcp.planners import PlannerConfig


@dataclasses.dataclass(frozen=True)
class Playing:
    """How every row is played and summarized: episodes, seed, planner options, path risk, learned policy, RPE."""

    episodes: int = 10_000
    seed: int = 0
    planner: PlannerConfig = PlannerConfig()
    path_risk: str = "departed"
    greedy: bool = False
    epsilon: float = EQN_EPSILON
    rpe_zero: str = "exclude"


def table_policies(spec, learned=None) -> tuple[str, ...]:
    """The rows of table ``spec``: its navigators, then ``learned``'s network when there is one."""
    return spec.heuristic_rows + ((learned.net_name,) if learned is not None else ())


def evaluate_row(name: str, setting: Setting, options: EnvOptions, playing: Playing, learned=None) -> dict:
    """The summary of policy ``name`` (``"optimal"`` adds ``expected_optimum``), with its ``seconds``."""
    t0 = time.perf_counter()
    key = jax.random.PRNGKey(playing.seed)
    if name in NETS:
        env, params = make_env(setting, options, learned)
        final = evaluate_learned(env, params, learned, key, playing.episodes, playing.greedy, playing.epsilon,
                                 playing.planner, playing.path_risk)
    elif name == "optimal":
        env, params = make_env(setting, options)
        optimal = evaluate_optimal(env, params, key, playing.episodes)
        final = optimal.final
    else:
        env, params = make_env(setting, options)
        final = evaluate_heuristic(env, params, name, key, playing.episodes, playing.planner, playing.path_risk)
    jax.block_until_ready(final)
    row = summarize(final, playing.rpe_zero)
    if name == "optimal":
        row["expected_optimum"] = optimal.expected_optimum
    row["seconds"] = round(time.perf_counter() - t0, 3)
    return row


#: Bytes per dropped reward unit and episode while the episodes' items are drawn (the unit draws, their
#: indices and masks; :func:`jaxdc.core.sampling.drop_units`).
DROP_BYTES_PER_UNIT = 32


def check_drop_fits(setting: Setting, playing: Playing) -> None:
    """``MemoryError`` if drawing ``total_reward`` units for every episode at once cannot be held (what to lower)."""
    memory.check_fits(DROP_BYTES_PER_UNIT * setting.total_reward * playing.episodes,
                      f"dropping {setting.total_reward} reward units in each of {playing.episodes} episodes",
                      "the total reward or the number of episodes")


def evaluate_rows(policies, setting: Setting, options: EnvOptions, playing: Playing, learned=None,
                  progress: Callable[[str, dict], None] | None = None) -> dict:
    """``{policy: summary}`` of each of ``policies`` in order; ``progress(name, summary)`` after each row.

    A request too large for the machine's memory (:func:`check_drop_fits`, and the checks of
    :mod:`jaxdc.core.memory` inside the evaluation) raises ``MemoryError`` before the first row is played.
    """
    check_drop_fits(setting, playing)
    out = {}
    for name in policies:
        out[name] = evaluate_row(name, setting, options, playing, learned)
        if progress:
            progress(name, out[name])
    return out
