"""Train a DCG network (VNN, IMNN, EMNN, OMN + CoNN; section 5.4) with synchronous A2C (Algorithms 10-12).

    python -m train.dcg --net omn_conn --energy 15 --steps 1000000 --seed 0

writes into ``--out`` (default ``runs/dcg-NET-eENERGY-sSEED``):

* ``config.json``: the run's settings;
* ``metrics.csv``: one row per evaluation (training losses -- for EMNN and
  OMN + CoNN also the opponent-action cross-entropy ``aux_loss`` and the
  training accuracy ``aux_accuracy`` --, the mean reward of the training
  episodes, and the evaluation: mean/SD episode reward and mean RPE over
  ``--eval-episodes`` games of the stochastic policy, and for EMNN/OMN the
  opponent-action accuracy ``eval_opponent_accuracy`` over a rollout);
* ``checkpoints/``: orbax checkpoints of the whole training state at every
  evaluation (the last ``--keep``).

``--resume`` continues from the latest checkpoint and ends with the same
parameters as an uninterrupted run. A NaN loss stops the run (exit status
3) before it is checkpointed. ``--ship [PATH]`` writes the final parameters
with :func:`jaxdc.pretrained.save` (default ``jaxdc/assets/dcg/NET.msgpack``).

Losses: VNN and IMNN the A2C loss (section 5.4.2); EMNN adds ``--alpha``
times the cross-entropy of Eq. 5.1 (Algorithm 11; 0.001, or 0.0001);
OMN + CoNN adds OMN's cross-entropy with weight 1, which trains OMN alone
(Algorithm 12; see :mod:`jaxdc.nets.omn_conn`), so ``--alpha`` does not
apply to it. ``--omn-lr`` (an option, not in the thesis) gives OMN's
parameters their own initial learning rate (``A2CConfig.aux_lr``).
``--reward-area S`` (an option, not in the thesis) trains on the one-item
game of section 5.5.5 instead of the standard one (docs/dcg.md).
``--energy-range LOW HIGH`` (beyond the thesis) draws each episode's maximum
energy among the integers of the range (``--energy-tilt A``: by a power law
that weights the low budgets), and ``--observation general`` shows
the collector its budget (docs/generalisation.md): one network for every
maximum energy. ``--collectors K`` (beyond the thesis) trains one network shared by
the ``K`` collectors of the team game (:class:`jaxdc.dcg.team.DCGTeam`) on the team
reward (:mod:`jaxdc.training.dcg`). ``--init-from NET|PATH`` (beyond the thesis) starts
from a trained network of the same kind instead of a fresh initialisation (a
one-collector network starting a team: the team starts as its copies,
:func:`jaxdc.training.dcg.start_params`). ``--algo mappo`` (beyond the thesis,
with ``--collectors`` >= 2) trains the team with a centralised critic on the
world state (MAPPO; :mod:`jaxdc.agents.centralised`) instead of each
collector's own value (``ippo``, the default); ``--ship`` writes the actor alone.

The learner options of ``train.dcp`` (``--gae-lambda``, ``--clip-eps``,
``--epochs``, ``--minibatches``, ``--normalize-advantages``,
``--reset-slots``; not in the thesis) and ``--seeds``/``--devices`` come
from the same place, :func:`jaxdc.cli.train_common.add_a2c_arguments`. ``--seeds
0,1,2`` trains independent runs in one vmapped program, each with its own
``metrics-sSEED.csv``.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys

from jaxdc import pretrained
from jaxdc.agents.a2c import A2CConfig
from jaxdc.cli.args import integer, nonnegative_float, positive_float, positive_int, real
from jaxdc.cli.train_common import (
    EXIT_NAN,  # noqa: F401  (re-exported: the exit status after a NaN loss, as tests and scripts read it)
    a2c_settings,
    add_a2c_arguments,
    add_config_arguments,
    config_file,
    fmt,
    report_done,
    run_control,
    run_outputs,
    seed_tag,
    train_from_command_line,
    training_energy,
)
from jaxdc.core.energy import ENERGY_SCALE, MAX_ENERGY_TILT
from jaxdc.core.masks import MASKS
from jaxdc.dcg.env import OBSERVATIONS
from jaxdc.dcg.opponents import STANDARD_STRATEGIES
from jaxdc.dcg.team.state import MAX_COLLECTORS
from jaxdc.io import check_not_input, check_output_path
from jaxdc.nets.registry import ALGOS
from jaxdc.training.dcg import NETS, DCGRun, DCGSettings, make_game, settings_from_metadata
from jaxdc.training.distributed import is_primary

#: EMNN's default weight of Eq. 5.1 (section 5.5.2).
ALPHA = 0.001


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m train.dcg", description=__doc__.split("\n")[0])
    p.add_argument("--net", choices=NETS, default="omn_conn", help="network to train (section 5.4)")
    p.add_argument("--alpha", type=nonnegative_float("--alpha"), default=None,
                   help="EMNN: weight of the opponent-action cross-entropy (Eq. 5.1; default 0.001, or 0.0001)")
    p.add_argument("--omn-lr", type=positive_float("--omn-lr"), default=None,
                   help="OMN + CoNN: initial learning rate of OMN's parameters, annealed to 0 like --lr by OMN's own "
                        "Adam (default: --lr, Algorithm 12's one update). Not in the thesis")
    p.add_argument("--energy", type=training_energy("--energy"), default=15.0,
                   help="maximum (and initial) energy (15; 10 and 20 in Figs. 5.8-5.9)")
    p.add_argument("--grid-size", type=integer("--grid-size", low=2), default=5, help="N (>= 2)")
    p.add_argument("--total-reward", type=positive_int("--total-reward"), default=None,
                   help="sum of the item rewards (default 10, section 5.5.1; 1 with --reward-area)")
    p.add_argument("--reward-area", type=positive_int("--reward-area"), default=None, metavar="S",
                   help="train on the game of section 5.5.5 (Figs. 5.10-5.12): one unit item uniform in the "
                        "bottom-right S x S square. Not in the thesis, which trains on the standard game only")
    p.add_argument("--min-reward-area", type=positive_int("--min-reward-area"), default=None, metavar="M",
                   help="with --reward-area S: each training episode draws its square's size uniformly from M..S "
                        "(one network for every size; beyond the thesis)")
    p.add_argument("--strategies", default=",".join(STANDARD_STRATEGIES),
                   help="comma-separated opponent strategies, one drawn per episode")
    p.add_argument("--history", type=integer("--history", low=1), default=10,
                   help="k, the previous agent planes read by IMNN/EMNN/OMN+CoNN (>= 1; VNN ignores it)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=100, help="episode step cap")
    p.add_argument("--out", default=None, help="run folder (default runs/dcg-NET-eENERGY-sSEED)")
    p.add_argument("--init-from", default=None, metavar="NET|PATH",
                   help="start from a trained network of the same kind (a shipped name, a .msgpack or a run folder) "
                        "instead of a fresh initialisation; a one-collector network starting a team (--collectors) "
                        "reads the teammates plane with zero weights, so the team starts as its copies. Not in "
                        "the thesis")
    p.add_argument("--ship", nargs="?", const="", default=None, metavar="PATH",
                   help="after training, write the final parameters with jaxdc.pretrained.save "
                        "(default jaxdc/assets/dcg/NET.msgpack)")
    g = p.add_argument_group("per-episode budgets (beyond the thesis; docs/generalisation.md)")
    g.add_argument("--observation", choices=OBSERVATIONS, default="thesis",
                   help="thesis: items, agent and history planes; general: also the episode's maximum energy plane, "
                        f"energies divided by {ENERGY_SCALE:g}")
    g.add_argument("--energy-range", nargs=2, type=training_energy("--energy-range"), metavar=("LOW", "HIGH"),
                   default=None, help="each episode's maximum energy: a whole number in [LOW, HIGH] (replaces "
                                      "--energy; the evaluation during training draws from the range too)")
    g.add_argument("--energy-tilt", type=real("--energy-tilt", -MAX_ENERGY_TILT, MAX_ENERGY_TILT), default=0.0,
                   metavar="A", help="with --energy-range: draw the maximum energy with density proportional to "
                                     "E**-A (0: uniform, the default; 1: log-uniform; A > 0 weights the low budgets)")
    g.add_argument("--mask", choices=MASKS, default="none",
                   help="train (and evaluate) the collector under an action mask: reach_base, a move must leave the "
                        "energy to get home; reach_base_or_item, or to reach an item, or it takes one (default "
                        "none, the thesis' policy; one collector only)")
    g = p.add_argument_group("the team game (beyond the thesis; docs/dcg.md)")
    g.add_argument("--collectors", type=integer("--collectors", low=1, high=MAX_COLLECTORS), default=1,
                   help=f"k collectors (1..{MAX_COLLECTORS}) sharing one network and the team reward "
                        "(independent actor-critic with parameter sharing: IPPO with the PPO-style options)")
    g.add_argument("--algo", choices=tuple(ALGOS), default="ippo",
                   help="the team learner: ippo (each collector's value on its own observation) or mappo (a "
                        "centralised critic on the world state, Yu et al. 2022; needs --collectors >= 2)")
    add_a2c_arguments(p)
    add_config_arguments(p, "dcg")
    return p


def settle(args):
    """``(DCGSettings, RunControl)`` of the parsed arguments; a ``ValueError`` names a bad combination."""
    if args.ship is not None and args.seeds is not None and len(args.seeds) > 1:
        raise ValueError(f"--ship writes one network; train one seed (--seed), not --seeds {args.seeds}")
    if args.alpha is not None and args.net != "emnn":
        raise ValueError(f"--alpha weights EMNN's cross-entropy (Eq. 5.1) and applies to --net emnn only, "
                         f"not {args.net!r}")
    alpha = ALPHA if args.alpha is None else args.alpha
    aux_coef = alpha if args.net == "emnn" else 1.0
    config = A2CConfig(**a2c_settings(args), aux_coef=aux_coef, aux_lr=args.omn_lr)
    settings = DCGSettings(net=args.net, config=config, alpha=alpha, energy=args.energy,
                           grid_size=args.grid_size, total_reward=args.total_reward,
                           strategies=tuple(args.strategies.split(",")), history=args.history,
                           max_steps=args.max_steps, reward_area=args.reward_area,
                           min_reward_area=args.min_reward_area, eval_episodes=args.eval_episodes,
                           greedy_eval=args.greedy_eval, observation=args.observation,
                           energy_range=None if args.energy_range is None else tuple(args.energy_range),
                           energy_tilt=args.energy_tilt, mask=args.mask,
                           collectors=args.collectors, init_from=args.init_from, algo=args.algo)
    make_game(settings)  # the game's options checked now (strategies, reward area, ...), not when the run builds it
    energy = f"{args.energy:g}" if args.energy_range is None else "{:g}-{:g}".format(*args.energy_range)
    team = ("" if args.collectors == 1 else f"-k{args.collectors}") + ("" if args.algo == "ippo" else f"-{args.algo}")
    out = args.out or os.path.join("runs", f"dcg-{args.net}{team}-e{energy}-s{seed_tag(args)}")
    return settings, run_control(args, out)


def Run(args) -> DCGRun:  # noqa: N802 - the name of train.dcp's
    """The training run of the parsed arguments."""
    return DCGRun(*settle(args))


def ship_path(args) -> str:
    """Where ``--ship`` writes (its PATH, or ``jaxdc/assets/dcg/NET.msgpack``)."""
    return args.ship or os.path.join(pretrained.ASSETS, "dcg", f"{args.net}.msgpack")


def _done_details(r: dict) -> str:
    acc = r.get("eval_opponent_accuracy")
    return f"RPE {fmt(r['eval_rpe'])}" + (f", opponent accuracy {fmt(acc)}" if acc is not None else "")


def main(argv=None) -> int:
    """Train (and ship); the exit status (0, or :data:`~jaxdc.cli.train_common.EXIT_NAN` after a NaN loss).

    Every flag, the run folder, its ``tb/`` and the ``--ship`` path are checked before any work; a bad value
    or combination is a usage error (exit 2) naming the flag.
    """
    parser = build_parser()

    def check_ship(args: argparse.Namespace) -> None:
        out = settle(args)[1].out
        start = {"--init-from": pretrained.read_paths(args.init_from, "dcg") if args.init_from else None}
        for path in run_outputs(out):  # the run folder must not be the network it starts from
            check_not_input(path, "--out", start)
        if args.ship is not None:
            blob = ship_path(args)
            blob = blob[: -len(".msgpack")] if blob.endswith(".msgpack") else blob
            for path in (blob + ".msgpack", blob + ".json"):
                check_output_path(path, "--ship", {"--config": config_file(args.config), "--out": run_outputs(out),
                                                   **start})

    trained = train_from_command_line(parser, argv, "dcg", settings_from_metadata, settle, DCGRun, check_ship)
    if trained is None:  # --list-configs
        return 0
    args, run, result = trained
    status = report_done(result, _done_details)
    if status:
        return status
    if args.ship is not None and is_primary():  # with several processes, process 0 ships
        argv_text = sys.argv[1:] if argv is None else list(argv)
        try:
            path = run.ship(args.ship, "python -m train.dcg " + shlex.join(argv_text))
        except ValueError as e:
            parser.error(str(e))
        print(f"shipped: {path}")
    return 0
