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
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys

import jax

from jaxdc.agents import a2c, nstep_q
from jaxdc.agents.a2c import A2CConfig
from jaxdc.cli.args import nonnegative_float, positive_float, positive_int
from jaxdc.core import grid
from jaxdc.core.paths import safest_paths
from jaxdc.core.rollout import run_episodes
from jaxdc.dcp import env as dcp_env
from jaxdc.dcp import navigators
from jaxdc.dcp.evaluate import summarize
from jaxdc.io import enable_compilation_cache
from jaxdc.nets import ACTOR_CRITICS, EQN, make_net
from train.common import (EXIT_NAN, TrainingRun, a2c_settings, add_a2c_arguments, algorithm_metadata,
                          learner_options_set, tensorboard_writer)

#: Networks of the command line: the actor-critics train with A2C, EQN with n-step Q-learning.
NETS = tuple(sorted(ACTOR_CRITICS)) + ("eqn",)
LOSS_METRICS = ("loss", "policy_loss", "value_loss", "entropy", "q_mean", "epsilon")
#: The ``A2CConfig`` settings n-step Q-learning shares (its config has no loss weights or learner options).
Q_FIELDS = ("total_steps", "num_envs", "t_max", "lr", "gamma", "max_grad_norm", "reset_slots")
CSV_FIELDS = ("env_steps", "updates", "wall_s", "steps_per_s", "lr", *LOSS_METRICS, "train_episodes",
              "train_reward", "eval_reward", "eval_reward_sd", "eval_energy",
              "eval_rpe")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m train.dcp", description=__doc__.split("\n")[0])
    p.add_argument("--net", choices=NETS, default="enn",
                   help="network to train (enn, linear, cnn: A2C; eqn: n-step Q-learning)")
    p.add_argument("--risk", choices=sorted(grid.RISK_PRESETS), default="high", help="risk preset (Table 4.2)")
    p.add_argument("--grid-size", type=positive_int("--grid-size"), default=8)
    p.add_argument("--total-reward", type=positive_int("--total-reward"), default=30)
    p.add_argument("--min-total-reward", type=positive_int("--min-total-reward"), default=None,
                   help="beyond the thesis: each training episode drops a number of units drawn uniformly from "
                        "MIN..--total-reward (one network for Tables 4.3, 4.6 and 4.8; default: always --total-reward)")
    p.add_argument("--energy", nargs=2, type=positive_float("--energy"), metavar=("INIT", "MAX"),
                   default=(8.0, 16.0), help="initial and maximal energy (Tables 4.3-4.8: 8 16)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=1000, help="episode step cap")
    add_a2c_arguments(p)  # --steps --seed(s) --envs --devices ... learner options ... --no-progress (train/common.py)
    p.add_argument("--target-every", type=positive_int("--target-every"), default=40_000,
                   help="eqn: environment steps between target-network copies")
    p.add_argument("--eval-epsilon", type=nonnegative_float("--eval-epsilon"), default=nstep_q.EVAL_EPSILON,
                   help="eqn: epsilon of the evaluation policy (section 4.5.5: 0.05)")
    p.add_argument("--out", default=None, help="run folder (default runs/dcp-NET-RISK-sSEED)")
    p.add_argument("--tensorboard", action="store_true",
                   help="also write the metrics as TensorBoard event files into OUT/tb (needs tensorboardX)")
    return p


class Run(TrainingRun):
    """One training command: settings, the (data parallel, maybe multi-seed) trainer, evaluation, checkpoints."""

    loss_metrics = LOSS_METRICS
    csv_fields = CSV_FIELDS

    def __init__(self, args):
        if args.energy[0] > args.energy[1]:
            raise ValueError(f"--energy: initial energy {args.energy[0]} exceeds the maximum {args.energy[1]}")
        if args.min_total_reward is not None and args.min_total_reward > args.total_reward:
            raise ValueError(f"--min-total-reward ({args.min_total_reward}) exceeds --total-reward "
                             f"({args.total_reward})")
        if args.net == "eqn" and learner_options_set(args):
            raise ValueError(f"{', '.join(learner_options_set(args))}: learner options of A2C; "
                             "--net eqn trains with n-step Q-learning, which has none of them")
        self.args = args
        if args.tensorboard:
            tensorboard_writer(None)  # fail before any work if tensorboardX is missing
        tag = "-".join(map(str, args.seeds or [args.seed]))
        self.out = args.out or os.path.join("runs", f"dcp-{args.net}-{args.risk}-s{tag}")
        self.ckpt_dir = os.path.join(self.out, "checkpoints")
        if args.net == "eqn":
            algo, self.net = nstep_q, EQN()
            self.config = nstep_q.QConfig(**a2c_settings(args, Q_FIELDS), target_every=args.target_every)
        else:
            algo, self.net = a2c, make_net(args.net)
            self.config = A2CConfig(**a2c_settings(args))
        self.env = dcp_env.DCP(grid_size=args.grid_size, total_reward=args.total_reward,
                               min_total_reward=args.min_total_reward)
        self.env_params = self.env.make_params(args.risk, tuple(args.energy), args.max_steps)
        table = jax.jit(safest_paths)(self.env_params.risk)  # once per run: the risk map is fixed
        self.heuristics = navigators.batched_heuristics(self.env_params, table)
        self.trainer = self.parallel_trainer(algo.make_train(self.config, self.env, self.env_params, self.net,
                                                             self.heuristics))
        self.metadata = {
            "format": 1, "net": args.net, "grid_size": args.grid_size, "total_reward": args.total_reward,
            "risk": args.risk, "energy": list(args.energy), "max_steps": args.max_steps,
            **({} if args.min_total_reward is None else {"min_total_reward": args.min_total_reward}),
            **({"seeds": self.seeds} if self.multi else {"seed": self.seeds[0]}),
            "algorithm": algorithm_metadata(self.config),
        }

        # evaluation always drops --total-reward units (the setting of the tables), also with --min-total-reward
        eval_env = dcp_env.DCP(grid_size=args.grid_size, total_reward=args.total_reward)

        def evaluate(params, key):
            policy = self.policy(params)
            return run_episodes(eval_env, self.env_params, policy, key, args.eval_episodes)

        self._evaluate = jax.jit(jax.vmap(evaluate) if self.multi else evaluate)

    def policy(self, params):
        """The evaluation policy: sampled from pi (argmax if --greedy-eval); EQN: epsilon-greedy."""
        a = self.args
        if a.net == "eqn":
            return nstep_q.make_q_policy(self.net, params, self.heuristics,
                                         epsilon=0.0 if a.greedy_eval else a.eval_epsilon)
        return a2c.make_policy(self.net, params, self.heuristics, greedy=a.greedy_eval)

    # -- one evaluation per seed ------------------------------------------------------------
    def evaluate(self, params, update: int) -> list[dict]:
        """Evaluation columns of each seed (keys from the seed and the update: as a single run's)."""
        results = jax.device_get(self._evaluate(params, self.eval_key(update)))
        rows = []
        for i in range(len(self.seeds)):
            s = summarize(jax.tree_util.tree_map(lambda x: x[i], results) if self.multi else results)
            rows.append({"eval_reward": s["reward"]["mean"], "eval_reward_sd": s["reward"]["sd"],
                         "eval_energy": s["energy"]["mean"], "eval_rpe": s["rpe"]["mean"]})
        return rows


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    enable_compilation_cache()
    try:
        result = Run(args).train()
    except ValueError as e:
        parser.error(str(e))
    if result["status"] == "nan":
        return EXIT_NAN
    for seed, r in result.get("per_seed", []):
        print(f"done: seed {seed}, {r['env_steps']} steps, eval reward {r['eval_reward']:.3f} "
              f"(energy {r['eval_energy']:.2f}, RPE {r['eval_rpe']:.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
