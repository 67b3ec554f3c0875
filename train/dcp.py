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

from jaxdc.agents import a2c, nstep_q, parallel
from jaxdc.agents.a2c import A2CConfig
from jaxdc.cli import nonnegative_float, positive_float, positive_int
from jaxdc.core import grid
from jaxdc.core.paths import safest_paths
from jaxdc.core.rollout import run_episodes
from jaxdc.dcp import env as dcp_env
from jaxdc.dcp import navigators
from jaxdc.dcp.evaluate import summarize
from jaxdc.io import enable_compilation_cache
from jaxdc.nets import ACTOR_CRITICS, EQN, make_net
from train.common import EXIT_NAN, TrainingRun, add_a2c_arguments, tensorboard_writer

#: Networks of the command line: the actor-critics train with A2C, EQN with n-step Q-learning.
NETS = tuple(sorted(ACTOR_CRITICS)) + ("eqn",)
LOSS_METRICS = ("loss", "policy_loss", "value_loss", "entropy", "q_mean", "epsilon")
CSV_FIELDS = ("env_steps", "updates", "wall_s", "steps_per_s", "lr", *LOSS_METRICS, "train_episodes",
              "train_reward", "eval_reward", "eval_reward_sd", "eval_energy",
              "eval_rpe")


def _seed_list(text):
    try:
        seeds = [int(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--seeds must be comma-separated ints, e.g. 0,1,2, got {text!r}") from None
    if len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(f"--seeds must be distinct, got {text!r}")
    return seeds


def _unit_interval(name, low_open=False):
    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (0 < v < 1 if low_open else 0 <= v <= 1):
            raise argparse.ArgumentTypeError(f"{name} must be in {'(0, 1)' if low_open else '[0, 1]'}, got {text!r}")
        return v

    return parse


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
    add_a2c_arguments(p)  # --steps --seed --envs --t-max --lr ... --keep --no-progress (train/common.py)
    p.add_argument("--seeds", type=_seed_list, default=None,
                   help="several independent runs at once (vmapped), e.g. 0,1,2; replaces --seed")
    p.add_argument("--devices", type=positive_int("--devices"), default=None,
                   help="devices to split the environment batch over (default: all; --envs must be a multiple)")
    p.add_argument("--reset-slots", type=positive_int("--reset-slots"), default=None,
                   help="fresh initial states drawn per step (default: one per environment)")
    g = p.add_argument_group("learner options beside Algorithm 10 (not in the thesis; see docs/learning.md)")
    g.add_argument("--gae-lambda", type=_unit_interval("--gae-lambda"), default=1.0,
                   help="lambda-returns / GAE (1: the n-step returns of Algorithm 10)")
    g.add_argument("--clip-eps", type=_unit_interval("--clip-eps", low_open=True), default=None,
                   help="PPO clipping of the probability ratio (default: none, plain policy gradient)")
    g.add_argument("--epochs", type=positive_int("--epochs"), default=1, help="passes over each rollout")
    g.add_argument("--minibatches", type=positive_int("--minibatches"), default=1,
                   help="shuffled minibatches per pass (must divide envs * t-max)")
    g.add_argument("--normalize-advantages", action="store_true", help="standardize advantages per minibatch")
    p.add_argument("--target-every", type=positive_int("--target-every"), default=40_000,
                   help="eqn: environment steps between target-network copies")
    p.add_argument("--eval-epsilon", type=nonnegative_float("--eval-epsilon"), default=nstep_q.EVAL_EPSILON,
                   help="eqn: epsilon of the evaluation policy (section 4.5.5: 0.05)")
    p.add_argument("--out", default=None, help="run folder (default runs/dcp-NET-RISK-sSEED)")
    p.add_argument("--tensorboard", action="store_true",
                   help="also write the metrics as TensorBoard event files into OUT/tb (needs tensorboardX)")
    return p


#: Learner options beside Algorithm 10 and their defaults (the faithful learner).
LEARNER_OPTIONS = {"gae_lambda": 1.0, "clip_eps": None, "epochs": 1, "minibatches": 1, "normalize_advantages": False}


def _algorithm_metadata(config) -> dict:
    """The config as checkpoint metadata; learner options at their defaults are left out, so checkpoints of
    faithful runs written before the options existed still resume."""
    return {k: v for k, v in dataclasses.asdict(config).items()
            if not (k in LEARNER_OPTIONS and v == LEARNER_OPTIONS[k])}


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
        self.args = args
        if args.tensorboard:
            tensorboard_writer(None)  # fail before any work if tensorboardX is missing
        self.seeds = args.seeds or [args.seed]
        self.multi = len(self.seeds) > 1
        tag = "-".join(map(str, self.seeds))
        self.out = args.out or os.path.join("runs", f"dcp-{args.net}-{args.risk}-s{tag}")
        self.ckpt_dir = os.path.join(self.out, "checkpoints")
        common = dict(total_steps=args.steps, num_envs=args.envs, t_max=args.t_max, lr=args.lr, gamma=args.gamma,
                      max_grad_norm=args.max_grad_norm, reset_slots=args.reset_slots)
        if args.net == "eqn":
            algo, self.net = nstep_q, EQN()
            self.config = nstep_q.QConfig(**common, target_every=args.target_every)
        else:
            algo, self.net = a2c, make_net(args.net)
            self.config = A2CConfig(**common, entropy_coef=args.entropy, value_coef=args.value_coef,
                                    gae_lambda=args.gae_lambda, clip_eps=args.clip_eps, epochs=args.epochs,
                                    minibatches=args.minibatches, normalize_advantages=args.normalize_advantages)
        self.env = dcp_env.DCP(grid_size=args.grid_size, total_reward=args.total_reward,
                               min_total_reward=args.min_total_reward)
        self.env_params = self.env.make_params(args.risk, tuple(args.energy), args.max_steps)
        table = jax.jit(safest_paths)(self.env_params.risk)  # once per run: the risk map is fixed
        self.heuristics = navigators.batched_heuristics(self.env_params, table)
        available = len(jax.devices())
        if args.devices is not None and args.devices > available:
            raise ValueError(f"--devices {args.devices}: JAX sees only {available} device(s)")
        devices = args.devices or available
        if args.envs % devices:
            raise ValueError(f"--envs ({args.envs}) must be divisible by the number of devices ({devices}); "
                             "change --envs or pass --devices")
        self.mesh = parallel.data_mesh(devices)
        self.trainer = parallel.parallelize(algo.make_train(self.config, self.env, self.env_params, self.net,
                                                            self.heuristics),
                                            self.mesh, len(self.seeds) if self.multi else None)
        self.metadata = {
            "format": 1, "net": args.net, "grid_size": args.grid_size, "total_reward": args.total_reward,
            "risk": args.risk, "energy": list(args.energy), "max_steps": args.max_steps,
            **({} if args.min_total_reward is None else {"min_total_reward": args.min_total_reward}),
            **({"seeds": self.seeds} if self.multi else {"seed": self.seeds[0]}),
            "algorithm": _algorithm_metadata(self.config),
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

    # -- state ------------------------------------------------------------------------------
    def _keys(self, offset: int = 0):
        keys = [jax.random.PRNGKey(s + offset) for s in self.seeds]
        return jax.numpy.stack(keys) if self.multi else keys[0]

    def init_key(self):
        return self._keys()

    def place(self, state):
        return parallel.place(state, self.mesh, seed_axis=self.multi)

    # -- one evaluation per seed ------------------------------------------------------------
    def evaluate(self, params, update: int) -> list[dict]:
        """Evaluation columns of each seed (keys from the seed and the update: as a single run's)."""
        keys = jax.vmap(jax.random.fold_in, in_axes=(0, None))(self._keys(1_000_003), update) if self.multi else \
            jax.random.fold_in(self._keys(1_000_003), update)
        results = jax.device_get(self._evaluate(params, keys))
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
