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
from the same place, :func:`train.common.add_a2c_arguments`. ``--seeds
0,1,2`` trains independent runs in one vmapped program, each with its own
``metrics-sSEED.csv``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shlex
import sys

import jax
import jax.numpy as jnp

from jaxdc import pretrained
from jaxdc.agents import a2c
from jaxdc.agents.a2c import A2CConfig
from jaxdc.cli.args import integer, nonnegative_float, positive_float, positive_int
from jaxdc.core.env import step_batch
from jaxdc.core.rollout import run_episodes
from jaxdc.dcg.env import DCG
from jaxdc.dcg.opponents import STANDARD_STRATEGIES
from jaxdc.dcp.evaluate import summarize
from jaxdc.io import enable_compilation_cache
from jaxdc.nets import DCG_NETS, make_dcg_net
from train.common import EXIT_NAN, TrainingRun, a2c_settings, add_a2c_arguments

NETS = tuple(DCG_NETS)
#: Networks with the opponent-action head (``has_aux``).
AUX_NETS = ("emnn", "omn_conn")
LOSS_METRICS = ("loss", "policy_loss", "value_loss", "entropy", "aux_loss", "aux_accuracy")
CSV_FIELDS = ("env_steps", "updates", "wall_s", "steps_per_s", "lr", *LOSS_METRICS, "train_episodes",
              "train_reward", "eval_reward", "eval_reward_sd", "eval_rpe", "eval_opponent_accuracy")
#: Rollout of the opponent-accuracy evaluation: environments x steps.
ACCURACY_ENVS, ACCURACY_STEPS = 64, 64


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


def opponent_accuracy(env, env_params, net, params, key, num_envs: int = ACCURACY_ENVS,
                      steps: int = ACCURACY_STEPS):
    """Share of steps on which the argmax of the opponent-action head equals ``o_t`` (section 5.5.3).

    ``num_envs`` games played for ``steps`` steps with the stochastic policy (auto-reset); the
    prediction at ``(s_t, h_t)`` is scored against the opponent's next action ``o_t``, the label
    of Eq. 5.1.
    """
    k_reset, k_run = jax.random.split(key)
    obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(k_reset, num_envs), env_params)

    def step(carry, k):
        obs, state = carry
        k_act, k_env = jax.random.split(k)
        logits, _, opp_logits = net.apply(params, obs)
        action = jax.random.categorical(k_act, logits).astype(jnp.int32)
        obs2, state2, *_, info = step_batch(env, k_env, state, action, env_params)
        return (obs2, state2), jnp.mean(jnp.argmax(opp_logits, -1) == info["opponent_action"])

    _, hits = jax.lax.scan(step, (obs, state), jax.random.split(k_run, steps))
    return jnp.mean(hits)


def make_env(args) -> tuple[DCG, object]:
    """The DCG of the run (section 5.5.1 settings by default) and its params; VNN's needs no history planes."""
    history_net = args.net != "vnn"
    env = DCG(grid_size=args.grid_size, total_reward=args.total_reward, strategies=args.strategies,
              history=args.history if history_net else 1, obs_history=history_net, reward_area=args.reward_area,
              min_reward_area=args.min_reward_area)
    return env, env.make_params(energy=args.energy, max_steps=args.max_steps)


class Run(TrainingRun):
    """One DCG training run of the command line."""

    loss_metrics = LOSS_METRICS
    csv_fields = CSV_FIELDS

    def __init__(self, args):
        self.args = args
        self.net = make_dcg_net(args.net, args.history)  # validates net and k
        self.env, self.env_params = make_env(args)  # validates grid, strategies, energy
        tag = "-".join(map(str, args.seeds or [args.seed]))
        self.out = args.out or os.path.join("runs", f"dcg-{args.net}-e{args.energy:g}-s{tag}")
        self.ckpt_dir = os.path.join(self.out, "checkpoints")
        if args.omn_lr is not None and args.net != "omn_conn":
            raise ValueError(f"--omn-lr sets OMN's learning rate and applies to --net omn_conn only, not {args.net!r}")
        if args.ship is not None and args.seeds is not None and len(args.seeds) > 1:
            raise ValueError(f"--ship writes one network; train one seed (--seed), not --seeds {args.seeds}")
        aux = args.net in AUX_NETS
        aux_coef = args.alpha if args.net == "emnn" else 1.0
        self.config = A2CConfig(**a2c_settings(args), aux_coef=aux_coef, aux_lr=args.omn_lr)
        self.trainer = self.parallel_trainer(a2c.make_train(
            self.config, self.env, self.env_params, self.net,
            aux_target=(lambda info: info["opponent_action"]) if aux else None))
        self.metadata = {
            "format": 1, "net": args.net, "problem": "dcg", "grid_size": args.grid_size,
            "total_reward": self.env.total_reward,
            "strategies": list(self.env.strategies), "energy": args.energy,
            "max_steps": args.max_steps, "history": args.history if args.net != "vnn" else 0,
            "alpha": args.alpha if args.net == "emnn" else None,
            **({"seeds": self.seeds} if self.multi else {"seed": self.seeds[0]}),
            "algorithm": dataclasses.asdict(self.config),
        }
        if args.reward_area is not None:  # only when set, so that runs made before the option still resume
            self.metadata["reward_area"] = args.reward_area
        if args.min_reward_area is not None:
            self.metadata["min_reward_area"] = args.min_reward_area

        def evaluate(params, key):
            k_ep, k_acc = jax.random.split(key)
            policy = a2c.make_policy(self.net, params, greedy=args.greedy_eval)
            finals = run_episodes(self.env, self.env_params, policy, k_ep, args.eval_episodes)
            acc = opponent_accuracy(self.env, self.env_params, self.net, params, k_acc) if aux else jnp.nan
            return finals, acc

        self._evaluate = jax.jit(jax.vmap(evaluate) if self.multi else evaluate)

    def evaluate(self, params, update: int) -> list[dict]:
        """Evaluation columns of each seed (keys from the seed and the update: as a single run's)."""
        finals, acc = jax.device_get(self._evaluate(params, self.eval_key(update)))
        rows = []
        for i in range(len(self.seeds)):
            s = summarize(jax.tree_util.tree_map(lambda x: x[i], finals) if self.multi else finals)
            row = {"eval_reward": s["reward"]["mean"], "eval_reward_sd": s["reward"]["sd"],
                   "eval_rpe": s["rpe"]["mean"]}
            if self.args.net in AUX_NETS:
                row["eval_opponent_accuracy"] = float(acc[i] if self.multi else acc)
            rows.append(row)
        return rows

    def ship(self, path: str, command: str) -> str:
        """Write the final parameters and their metadata (:func:`jaxdc.pretrained.save`)."""
        path = path or os.path.join(pretrained.ASSETS, "dcg", f"{self.args.net}.msgpack")
        a = self.args
        meta = {k: v for k, v in self.metadata.items() if k not in ("format", "algorithm")}
        meta.update(steps=a.steps, obs_history=self.env.obs_history, command=command,
                    algorithm={k: v for k, v in dataclasses.asdict(self.config).items()})
        return pretrained.save(path, self.final_state.params, meta)


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


if __name__ == "__main__":
    sys.exit(main())
