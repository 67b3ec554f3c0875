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

from jaxdc.agents.a2c import A2CConfig
from jaxdc.cli.args import integer, nonnegative_float, positive_float, positive_int
from jaxdc.cli.train_common import EXIT_NAN, a2c_settings, add_a2c_arguments, run_control, seed_tag
from jaxdc.dcg.opponents import STANDARD_STRATEGIES
from jaxdc.io import enable_compilation_cache
from jaxdc.training.dcg import NETS, DCGRun, DCGSettings


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m train.dcg", description=__doc__.split("\n")[0])
    p.add_argument("--net", choices=NETS, default="omn_conn", help="network to train (section 5.4)")
    p.add_argument("--alpha", type=nonnegative_float("--alpha"), default=0.001,
                   help="EMNN: weight of the opponent-action cross-entropy (Eq. 5.1; 0.001 or 0.0001)")
    p.add_argument("--omn-lr", type=positive_float("--omn-lr"), default=None,
                   help="OMN + CoNN: initial learning rate of OMN's parameters, annealed to 0 like --lr by OMN's own "
                        "Adam (default: --lr, Algorithm 12's one update). Not in the thesis")
    p.add_argument("--energy", type=positive_float("--energy"), default=15.0,
                   help="maximum (and initial) energy (15; 10 and 20 in Figs. 5.8-5.9)")
    p.add_argument("--grid-size", type=integer("--grid-size"), default=5, help="N (>= 2)")
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
    p.add_argument("--history", type=integer("--history"), default=10,
                   help="k, the previous agent planes read by IMNN/EMNN/OMN+CoNN (>= 1; VNN ignores it)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=100, help="episode step cap")
    p.add_argument("--out", default=None, help="run folder (default runs/dcg-NET-eENERGY-sSEED)")
    p.add_argument("--ship", nargs="?", const="", default=None, metavar="PATH",
                   help="after training, write the final parameters with jaxdc.pretrained.save "
                        "(default jaxdc/assets/dcg/NET.msgpack)")
    add_a2c_arguments(p)
    return p


def settle(args):
    """``(DCGSettings, RunControl)`` of the parsed arguments; a ``ValueError`` names a bad combination."""
    if args.ship is not None and args.seeds is not None and len(args.seeds) > 1:
        raise ValueError(f"--ship writes one network; train one seed (--seed), not --seeds {args.seeds}")
    aux_coef = args.alpha if args.net == "emnn" else 1.0
    config = A2CConfig(**a2c_settings(args), aux_coef=aux_coef, aux_lr=args.omn_lr)
    settings = DCGSettings(net=args.net, config=config, alpha=args.alpha, energy=args.energy,
                           grid_size=args.grid_size, total_reward=args.total_reward,
                           strategies=tuple(args.strategies.split(",")), history=args.history,
                           max_steps=args.max_steps, reward_area=args.reward_area,
                           min_reward_area=args.min_reward_area, eval_episodes=args.eval_episodes,
                           greedy_eval=args.greedy_eval)
    out = args.out or os.path.join("runs", f"dcg-{args.net}-e{args.energy:g}-s{seed_tag(args)}")
    return settings, run_control(args, out)


def Run(args) -> DCGRun:  # noqa: N802 - the name of train.dcp's
    """The training run of the parsed arguments."""
    return DCGRun(*settle(args))


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    enable_compilation_cache()
    try:
        run = Run(args)
        result = run.train()
    except (ValueError, TypeError) as e:
        parser.error(str(e))
    if result["status"] == "nan":
        return EXIT_NAN
    for seed, r in result.get("per_seed", []):
        acc = r.get("eval_opponent_accuracy")
        print(f"done: seed {seed}, {r['env_steps']} steps, eval reward {r['eval_reward']:.3f} "
              f"(RPE {r['eval_rpe']:.3f}" + (f", opponent accuracy {acc:.3f})" if acc is not None else ")"))
    if args.ship is not None:
        argv_text = sys.argv[1:] if argv is None else list(argv)
        path = run.ship(args.ship, "python -m train.dcg " + shlex.join(argv_text))
        print(f"shipped: {path}")
    return 0
