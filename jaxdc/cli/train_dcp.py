"""Train a network on the DCP: synchronous A2C (sections 4.4.3, 4.5) or n-step Q-learning for EQN (4.5.5).

    python -m train.dcp --net enn --risk high --steps 1000000 --seed 0

writes into ``--out`` (default ``runs/dcp-NET-RISK-sSEED``):

* ``config.json``: the run's settings;
* ``metrics.csv``: one row per evaluation (training losses, the mean reward
  of the training episodes, and the evaluation over ``--eval-episodes``
  episodes of the stochastic policy);
* ``checkpoints/``: orbax checkpoints of the whole training state at every
  evaluation (the last ``--keep``).

``--resume`` continues from the latest checkpoint and ends with the same
parameters as an uninterrupted run. A NaN loss stops the run (exit status
3) before it is checkpointed, so the last checkpoint stays good.

The environment batch is split over all devices (``--devices N``: the first
N; ``jaxdc.agents.parallel``). ``--seeds 0,1,2`` trains independent runs in
one vmapped program: one checkpoint holds them all, and each seed gets its
own ``metrics-sSEED.csv``. ``--tensorboard`` also writes the metrics as
TensorBoard event files into ``tb/`` (needs the ``tb`` extra: tensorboardX).
``--init-from NET|PATH`` (beyond the thesis) starts from a trained actor-critic of the same network, grid size
and observation instead of a fresh initialisation, recorded with the SHA-256 of its parameters (a network whose
body pools over the cells, ``--body-pool``, starts a run of any grid size). ``--grid-sizes 6 8 10`` (beyond the
thesis, with ``--body-pool``) trains one network on several grid sizes at once: the ``--envs`` environments are split
evenly over them, and the evaluation during training plays ``--grid-size``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os

from jaxdc import pretrained
from jaxdc.agents.a2c import A2CConfig
from jaxdc.agents.common import RunConfig
from jaxdc.agents.nstep_q import EVAL_EPSILON, QConfig
from jaxdc.cli.args import integer, positive_int, real, unit_interval
from jaxdc.cli.train_common import (
    A2C_FLAGS,
    EXIT_NAN,  # noqa: F401  (re-exported: the exit status after a NaN loss, as tests and scripts read it)
    a2c_settings,
    add_a2c_arguments,
    add_config_arguments,
    fmt,
    learner_options_set,
    report_done,
    run_control,
    run_outputs,
    seed_tag,
    train_from_command_line,
    training_energy,
)
from jaxdc.core import generators, grid
from jaxdc.core.energy import MAX_ENERGY_TILT
from jaxdc.core.sampling import MAX_TILT
from jaxdc.dcp.navigators import HEURISTIC_ROWS
from jaxdc.io import check_not_input
from jaxdc.nets.body import MAX_CONV_LAYERS, MAX_WIDTH, POOLS
from jaxdc.training.dcp import NETS, DCPRun, DCPSettings, settings_from_metadata

#: EQN's default environment steps between target-network copies (``QConfig.target_every``).
TARGET_EVERY = QConfig.target_every
#: The flags' settings n-step Q-learning shares with A2C: those of ``RunConfig`` (no loss weights or learner options).
Q_FIELDS = tuple(f for f in A2C_FLAGS if f in {field.name for field in dataclasses.fields(RunConfig)})


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m train.dcp", description=__doc__.split("\n")[0])
    p.add_argument("--net", choices=NETS, default="enn",
                   help="network to train (enn, linear, cnn: A2C; eqn: n-step Q-learning)")
    p.add_argument("--risk", choices=sorted(grid.RISK_PRESETS), default="high", help="risk preset (Table 4.2)")
    p.add_argument("--grid-size", type=integer("--grid-size", low=2), default=8, help="N (>= 2)")
    p.add_argument("--total-reward", type=positive_int("--total-reward"), default=30)
    p.add_argument("--min-total-reward", type=positive_int("--min-total-reward"), default=None,
                   help="beyond the thesis: each training episode drops a number of units drawn uniformly from "
                        "MIN..--total-reward (one network for Tables 4.3, 4.6 and 4.8; default: always --total-reward)")
    p.add_argument("--item-tilt", type=real("--item-tilt", -MAX_TILT, MAX_TILT), default=0.0, metavar="A",
                   help="beyond the thesis, with --min-total-reward: draw the unit count with density C**-A (A > 0 "
                        "weights the episodes with few items; 1: log-uniform; default 0: uniform)")
    p.add_argument("--energy", nargs=2, type=training_energy("--energy"), metavar=("INIT", "MAX"),
                   default=(8.0, 16.0), help="initial and maximal energy, finite (Tables 4.3-4.8: 8 16)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=1000, help="episode step cap")
    g = p.add_argument_group("per-episode instances (beyond the thesis; docs/generalisation.md)")
    g.add_argument("--observation", choices=("thesis", "general"), default="thesis",
                   help="thesis: items and energy planes; general: also the risk map and the budget")
    g.add_argument("--risk-maps", choices=tuple(generators.GENERATORS), default=None,
                   help="each training episode draws its risk map from --map-seeds maps of this generator")
    g.add_argument("--map-seeds", nargs=2, type=integer("--map-seeds", low=0), metavar=("START", "COUNT"),
                   default=(0, 1024), help="the seeds of the training maps (held-out seeds are refused)")
    g.add_argument("--energy-range", nargs=2, type=training_energy("--energy-range"), metavar=("LOW", "HIGH"),
                   default=None, help="each training episode's maximum energy: a whole number in [LOW, HIGH]")
    g.add_argument("--energy-tilt", type=real("--energy-tilt", -MAX_ENERGY_TILT, MAX_ENERGY_TILT), default=0.0,
                   metavar="A", help="with --energy-range: draw the maximum energy with density E**-A (A > 0 weights "
                                     "the small budgets; 1: log-uniform; default 0: uniform)")
    g.add_argument("--init-fraction", type=unit_interval("--init-fraction"), default=0.5,
                   help="with --energy-range: initial energy = round(F * maximum) (default 0.5, as 8/16)")
    b = p.add_argument_group("the network's body (beyond the thesis; docs/generalisation.md)")
    b.add_argument("--body-features", nargs="+", type=positive_int("--body-features", MAX_WIDTH), default=None,
                   metavar="F", help=f"enn, eqn, cnn: the filter counts of the 3x3 convolutional layers, 1 to "
                                     f"{MAX_CONV_LAYERS} of them (default: the thesis' 32 16)")
    b.add_argument("--body-hidden", type=positive_int("--body-hidden", MAX_WIDTH), default=None, metavar="H",
                   help="enn, eqn, cnn: the units of the hidden dense layer (default: the thesis' 256)")
    b.add_argument("--body-pool", choices=POOLS, default=None,
                   help="enn, eqn, cnn: how the body reduces the grid: flatten (the thesis' default) or mean_max "
                        "(each filter's mean and maximum over the cells: the network plays every grid size)")
    b.add_argument("--heuristic-rows", type=int, choices=HEURISTIC_ROWS, default=10,
                   help="enn, eqn: the heuristic rows the network weighs: 10, the thesis' (section 4.4.3), or 11, "
                        "which adds Safe-Budget, the route to LPG's item that fits the energy")
    b.add_argument("--grid-sizes", nargs="+", type=integer("--grid-sizes", low=2), default=None, metavar="N",
                   help="actor-critics with --body-pool: train on these grid sizes at once, --grid-size among them "
                        "(the --envs environments split evenly over them; evaluation on --grid-size). Not in the "
                        "thesis")
    add_a2c_arguments(p)  # --steps --seed(s) --envs --devices ... learner options ... --no-progress
    add_config_arguments(p, "dcp")
    p.add_argument("--target-every", type=positive_int("--target-every"), default=None,
                   help="eqn: environment steps between target-network copies (default 40000)")
    p.add_argument("--eval-epsilon", type=unit_interval("--eval-epsilon"), default=None,
                   help="eqn: epsilon of the evaluation policy (section 4.5.5: 0.05)")
    p.add_argument("--out", default=None, help="run folder (default runs/dcp-NET-RISK-sSEED)")
    p.add_argument("--init-from", default=None, metavar="NET|PATH",
                   help="start from a trained network of the same kind, grid size (any, for a --body-pool network) "
                        "and observation (a shipped name, a .msgpack or a run folder) instead of a fresh "
                        "initialisation: e.g. enn_general fine-tuned on one --risk map. "
                        "Actor-critics only. Not in the thesis")
    p.add_argument("--tensorboard", action="store_true",
                   help="also write the metrics as TensorBoard event files into OUT/tb (needs tensorboardX)")
    return p


def settle(args):
    """``(DCPSettings, RunControl)`` of the parsed arguments; a ``ValueError`` names a bad combination."""
    if args.energy[0] > args.energy[1]:
        raise ValueError(f"--energy: initial energy {args.energy[0]} exceeds the maximum {args.energy[1]}")
    if args.min_total_reward is not None and args.min_total_reward > args.total_reward:
        raise ValueError(f"--min-total-reward ({args.min_total_reward}) exceeds --total-reward "
                         f"({args.total_reward})")
    if args.net == "eqn" and learner_options_set(args):
        raise ValueError(f"{', '.join(learner_options_set(args))}: learner options of A2C; "
                         "--net eqn trains with n-step Q-learning, which has none of them")
    q_only = [f for f, v in (("--target-every", args.target_every), ("--eval-epsilon", args.eval_epsilon))
              if v is not None]
    if args.net != "eqn" and q_only:
        raise ValueError(f"{', '.join(q_only)}: settings of n-step Q-learning, which applies to --net eqn only, "
                         f"not {args.net!r}")
    if args.net == "eqn":
        config = QConfig(**a2c_settings(args, Q_FIELDS),
                         target_every=TARGET_EVERY if args.target_every is None else args.target_every)
    else:
        config = A2CConfig(**a2c_settings(args))
    settings = DCPSettings(net=args.net, config=config, risk=args.risk, grid_size=args.grid_size,
                           total_reward=args.total_reward, min_total_reward=args.min_total_reward,
                           energy=tuple(args.energy), max_steps=args.max_steps, eval_episodes=args.eval_episodes,
                           greedy_eval=args.greedy_eval,
                           eval_epsilon=EVAL_EPSILON if args.eval_epsilon is None else args.eval_epsilon,
                           observation=args.observation, risk_maps=args.risk_maps, map_seeds=tuple(args.map_seeds),
                           energy_range=None if args.energy_range is None else tuple(args.energy_range),
                           init_fraction=args.init_fraction, init_from=args.init_from,
                           energy_tilt=args.energy_tilt, item_tilt=args.item_tilt,
                           body_features=None if args.body_features is None else tuple(args.body_features),
                           body_hidden=args.body_hidden, body_pool=args.body_pool,
                           heuristic_rows=args.heuristic_rows,
                           grid_sizes=None if args.grid_sizes is None else tuple(args.grid_sizes))
    out = args.out or os.path.join("runs", f"dcp-{args.net}-{args.risk}-s{seed_tag(args)}")
    return settings, run_control(args, out)


def Run(args) -> DCPRun:  # noqa: N802 - the name docs/learning.md uses
    """The training run of the parsed arguments (``Run(args).trainer``, ``Run(args).train()``)."""
    return DCPRun(*settle(args))


def main(argv=None) -> int:
    """Train; the exit status (0, or :data:`~jaxdc.cli.train_common.EXIT_NAN` after a NaN loss).

    Every flag, the run folder and its ``tb/`` are checked before any work; a bad value or combination is a
    usage error (exit 2) naming the flag.
    """
    def check_start(args: argparse.Namespace) -> None:  # the run folder must not be the network it starts from
        if args.init_from:
            start = {"--init-from": pretrained.read_paths(args.init_from, "dcp")}
            for path in run_outputs(settle(args)[1].out):
                check_not_input(path, "--out", start)

    trained = train_from_command_line(build_parser(), argv, "dcp", settings_from_metadata, settle, DCPRun,
                                      check_start)
    if trained is None:  # --list-configs
        return 0
    return report_done(trained[2], lambda r: f"energy {fmt(r['eval_energy'], '.2f')}, RPE {fmt(r['eval_rpe'])}")
