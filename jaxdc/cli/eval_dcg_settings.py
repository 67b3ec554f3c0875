"""The settled arguments of ``python -m eval.dcg``: one frozen settings record per subcommand.

Each record holds what its program (:mod:`jaxdc.cli.eval_dcg`) needs once the
flags are parsed and checked: ``from_args`` settles an ``argparse`` namespace
(a strategy set from ``--strategies``/``--double-blind``, ``--no-*`` flags
turned into positive fields) and raises ``ValueError`` naming the flag for a
combination the parser cannot refuse alone.
"""

from __future__ import annotations

import dataclasses
import math

from jaxdc.core.validate import value_text
from jaxdc.dcg.analysis.cache import EvaluationCache
from jaxdc.dcg.analysis.experiment import ExperimentSettings
from jaxdc.dcg.analysis.figures import EXPERIMENTS, FIGURES
from jaxdc.dcg.opponents import DOUBLE_BLIND_STRATEGIES


# -- settled arguments --------------------------------------------------------------------------
def _strategy_set(args):
    return DOUBLE_BLIND_STRATEGIES if args.double_blind else args.strategies


@dataclasses.dataclass(frozen=True)
class EvaluateSettings:
    """One evaluation: the collector (a run folder or file, or a shipped name), the game's changes, the games."""

    checkpoint: str | None
    net: str | None
    energy: float | None
    strategies: tuple | None
    reward_area: int | None
    max_steps: int | None
    greedy: bool
    episodes: int
    seed: int
    rpe_zero: str
    bound: bool
    json: bool
    out: str
    collectors: int | None = None  # the team game (beyond the thesis); None: the network's own
    mask: str | None = None  # an action mask (beyond the thesis; jaxdc.core.masks.MASKS); None: as trained
    run_seed: int | None = None  # the seed of a train.dcg --seeds run folder

    @classmethod
    def from_args(cls, args) -> "EvaluateSettings":
        return cls(args.checkpoint, args.net, args.energy, _strategy_set(args), args.reward_area, args.max_steps,
                   args.greedy, args.episodes, args.seed, args.rpe_zero, not args.no_bound, args.json, args.out,
                   args.collectors, args.mask, args.run_seed)


@dataclasses.dataclass(frozen=True)
class FigureSettings:
    """One ``figure`` run: the experiments, the parameter files, how the bars are played, where results go."""

    experiments: tuple
    nets_dir: str | None
    play: ExperimentSettings
    cache: EvaluationCache
    out: str
    img: str

    @classmethod
    def from_args(cls, args) -> "FigureSettings":
        names = tuple(EXPERIMENTS) if args.figure == "all" else (FIGURES[args.figure],)
        play = ExperimentSettings(args.episodes, args.seed, args.greedy, not args.no_bound, args.bound_episodes)
        return cls(names, args.nets_dir, play, EvaluationCache(args.cache, reuse=not args.no_cache), args.out,
                   args.img)


@dataclasses.dataclass(frozen=True)
class RenderSettings:
    """One drawn game: the collector, its opponent strategy and game, and the pictures."""

    checkpoint: str | None
    net: str | None
    strategy: str
    seed: int
    energy: float | None
    reward_area: int | None
    max_steps: int
    greedy: bool
    cols: int | None
    fps: int
    out: str
    run_seed: int | None = None  # the seed of a train.dcg --seeds run folder

    @classmethod
    def from_args(cls, args) -> "RenderSettings":
        if len(args.strategy) != 1:
            raise ValueError(f"--strategy takes one strategy, got {','.join(args.strategy)}")
        return cls(args.checkpoint, args.net, args.strategy[0], args.seed, args.energy, args.reward_area,
                   args.max_steps, args.greedy, args.cols, args.fps, args.out, args.run_seed)


@dataclasses.dataclass(frozen=True)
class OptimumSettings:
    """The sampled full-information bound: the game (constructor options and numeric settings), the games."""

    game: dict  # DCG(...) keyword arguments
    energy: float
    max_steps: int
    chase_tie: str
    episodes: int
    seed: int
    progress: bool
    json: bool
    out: str
    collectors: int = 1  # 2: the team bound (jaxdc.dcg.exact.team)
    fog_target: str = "visible"

    @classmethod
    def from_args(cls, args) -> "OptimumSettings":
        if not (math.isinf(args.energy) or args.energy == math.floor(args.energy)):
            raise ValueError("--energy must be a whole number or inf for the exact bound, got "
                             + value_text(args.energy))
        game = dict(grid_size=args.grid_size, total_reward=args.total_reward, history=1, obs_history=False,
                    strategies=_strategy_set(args), opponent_start=args.opponent_start,
                    patrol_target=args.patrol_target, items_on_base=not args.no_items_on_base,
                    reward_when_caught=not args.no_reward_when_caught, capture=args.capture,
                    safe_base=args.safe_base, opponent_enters_base=not args.opponent_out_of_base)
        return cls(game, args.energy, args.max_steps, args.chase_tie, args.episodes, args.seed,
                   not args.no_progress, args.json, args.out, args.collectors, args.fog_target)
