"""Regenerate the shipped parameters: the DCP's (``jaxdc/assets/dcp``, train with ``train.dcp``, then export)
and the strong DCG collectors (``jaxdc/assets/dcg/*_strong*``, ``train.dcg --ship``).

    python -m train.ship                      # all of them (6 runs of 1M steps, 2 at a time)
    python -m train.ship --only enn eqn       # some of them
    python -m train.ship --export-only        # re-export from finished run folders
    python -m train.ship --only enn_single_item   # the single-item ENN (beyond the thesis, 4M steps)
    python -m train.ship --only enn_long          # Table 4.3's ENN trained 16M steps (beyond the thesis)
    python -m train.ship --only enn_mix           # one 1M-step ENN for Tables 4.3, 4.6, 4.8 (beyond the thesis)
    python -m train.ship --only enn_ppo enn_ppo_low enn_ppo_energy16_32 enn_ppo_mix   # the PPO-style option, 1M steps
    python -m train.ship --only vnn_strong omn_conn_strong    # strong DCG collectors (docs/dcg.md, 3M steps)

Each shipped network is trained with the defaults of ``python -m train.dcp``
(the thesis' hyper-parameters, section 4.5), seed 0, 1M steps, in the
setting of the table it fills (section 4.5: the ENN of Table 4.3 also plays
Tables 4.6 and 4.8; Tables 4.4, 4.5 and 4.7 have their own ENNs; the linear learner and EQN
are trained in the setting of Table 4.3). The run folders are
``--runs/<name>`` (a finished or interrupted run is resumed, so rerunning is
cheap); the last checkpoint is exported with :func:`jaxdc.pretrained.save`,
its metadata holding the network, the problem, every environment setting, the
steps, the seed and the exact ``train.dcp`` command.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import time

#: name of the shipped file -> (the tables it fills, train.dcp arguments of its setting)
SHIPPED = {
    "enn": ("4.3, 4.6, 4.8", ["--net", "enn", "--risk", "high", "--energy", "8", "16"]),
    "enn_medium": ("4.4", ["--net", "enn", "--risk", "medium", "--energy", "8", "16"]),
    "enn_low": ("4.5", ["--net", "enn", "--risk", "low", "--energy", "8", "16"]),
    "enn_energy16_32": ("4.7", ["--net", "enn", "--risk", "high", "--energy", "16", "32"]),
    "linear": ("4.9", ["--net", "linear", "--risk", "high", "--energy", "8", "16"]),
    "eqn": ("4.10", ["--net", "eqn", "--risk", "high", "--energy", "8", "16"]),
}
#: Beyond the thesis, shipped: the best learners of the two goals of docs/learning.md. ``enn_long``: the
#: faithful A2C in Table 4.3's setting, trained 16M steps instead of 1M (goal: >= 10% above the thesis' ENN
#: reward). ``enn_single_item``: the best single-item learner (goal: >= 97% of the exact optimum of Table
#: 4.8's setting, ``jaxdc/dcp/optimal.py``); the thesis reuses the Table 4.3 ENN there, this one is trained on
#: the single-item setting itself and evaluated greedily (``eval.dcp --greedy``). ``enn_mix``: one ENN at the
#: thesis' 1M steps for Tables 4.3, 4.6 and 4.8, trained on episodes of 1..30 units (``--min-total-reward 1``)
#: with Adam at 3e-4 (docs/learning.md, "At the thesis' 1M steps").
BEYOND = {
    "enn_long": ("4.3 (beyond the thesis: 16M steps)",
                 ["--net", "enn", "--risk", "high", "--energy", "8", "16",
                  "--steps", "16000000", "--eval-every", "2000000", "--eval-episodes", "2000"]),
    "enn_single_item": ("4.8 (beyond the thesis: trained on one item)",
                        ["--net", "enn", "--risk", "high", "--total-reward", "1", "--energy", "8", "16",
                         "--steps", "4000000", "--eval-every", "1000000", "--eval-episodes", "2000", "--greedy-eval"]),
    "enn_mix": ("4.3, 4.6, 4.8 (beyond the thesis: 1..30 units per training episode, lr 3e-4)",
                ["--net", "enn", "--risk", "high", "--energy", "8", "16", "--min-total-reward", "1", "--lr", "3e-4",
                 "--eval-episodes", "2000"]),
}
#: The PPO-style option of ``train.dcp`` (docs/learning.md, "The PPO-style option at 1M steps"), the same
#: options for every table: the best learners at the thesis' 1M steps.
PPO = ["--envs", "32", "--t-max", "32", "--lr", "3e-4", "--clip-eps", "0.2", "--epochs", "4", "--minibatches", "4",
       "--gae-lambda", "0.95", "--normalize-advantages", "--reset-slots", "4",
       "--eval-every", "1000000", "--eval-episodes", "4000"]
BEYOND.update({  # the setting of the faithful ENN of the same tables, then the PPO options
    "enn_ppo": ("4.3, 4.6 (beyond the thesis: the PPO-style option)", [*SHIPPED["enn"][1], *PPO]),
    "enn_ppo_low": ("4.5 (beyond the thesis: the PPO-style option)", [*SHIPPED["enn_low"][1], *PPO]),
    "enn_ppo_energy16_32": ("4.7 (beyond the thesis: the PPO-style option)", [*SHIPPED["enn_energy16_32"][1], *PPO]),
    "enn_ppo_mix": ("4.3, 4.6, 4.8 (beyond the thesis: the PPO-style option, 1..30 units per training episode)",
                    [*SHIPPED["enn"][1], "--min-total-reward", "1", *PPO]),
})
#: The strong DCG collectors (docs/dcg.md, "Strong collectors"; beyond the thesis): the PPO-style options at
#: lr 1e-3, 3M steps (``NET_strong``) and the same recipe at the thesis' 1M steps (``NET_strong_1m``, Fig. 5.6).
#: ``train.dcg --ship`` writes each file itself.
DCG_STRONG_RECIPE = ["--envs", "32", "--t-max", "32", "--lr", "1e-3", "--clip-eps", "0.2", "--epochs", "4",
                     "--minibatches", "4", "--gae-lambda", "0.95", "--normalize-advantages", "--reset-slots", "4",
                     "--eval-every", "1000000", "--eval-episodes", "2000"]
DCG_STRONG = {f"{net}_strong{tag}": (figures, ["--net", net, "--steps", steps, *DCG_STRONG_RECIPE])
              for net in ("vnn", "imnn", "emnn", "omn_conn")
              for tag, steps, figures in (("", "3000000", "5.11, 5.16 (beyond the thesis: the strong recipe, 3M)"),
                                          ("_1m", "1000000", "5.6 (beyond the thesis: the strong recipe, 1M)"))}
#: One OMN+CoNN for every reward-area size (Fig. 5.11; beyond the thesis): the recipe for 5M steps on one item in
#: a square whose size each episode draws from 1..4 (``--min-reward-area``).
DCG_STRONG["omn_conn_strong_areas"] = (
    "5.11 (beyond the thesis: one network for reward-area sizes 1-4)",
    ["--net", "omn_conn", "--steps", "5000000", *DCG_STRONG_RECIPE, "--reward-area", "4", "--min-reward-area", "1"])
ALL = {**SHIPPED, **BEYOND}
EVERY = {**ALL, **DCG_STRONG}


def train_command(name: str, steps: int, seed: int, runs: str) -> list[str]:
    """The ``python -m train.dcp`` (or, for a DCG entry, ``train.dcg``) command line that trains shipped
    network ``name``.

    ``steps`` applies unless the entry fixes its own ``--steps`` (the beyond-the-thesis networks).
    """
    args = EVERY[name][1]
    own_steps = [] if "--steps" in args else ["--steps", str(steps)]
    if name in DCG_STRONG:
        return ["python", "-m", "train.dcg", *args, "--no-progress", "--seed", str(seed),
                "--out", os.path.join(runs, name), "--ship", f"jaxdc/assets/dcg/{name}.msgpack"]
    return ["python", "-m", "train.dcp", *args, *own_steps, "--seed", str(seed),
            "--out", os.path.join(runs, name), "--no-progress"]


def _last_row(run: str) -> dict:
    path = os.path.join(run, "metrics.csv")
    if not os.path.exists(path):
        return {}
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return rows[-1] if rows else {}


def export(name: str, run: str, command: list[str], out: str) -> str:
    """Export the last checkpoint of ``run`` as ``out/<name>.msgpack`` with its metadata (sections 4.4.3, 4.5)."""
    from jaxdc import pretrained
    from jaxdc.dcp import learned as learned_lib
    from jaxdc.dcp.env import DCP

    learned = learned_lib.load(run)
    meta = learned.metadata
    env = DCP(grid_size=meta["grid_size"], total_reward=meta["total_reward"])  # train.dcp's environment
    last = _last_row(run)
    metadata = {
        "net": learned.net_name, "problem": "dcp", **learned.setting(),
        **({"min_total_reward": meta["min_total_reward"]} if "min_total_reward" in meta else {}),
        "env": {"start": env.start, "items_on_base": env.items_on_base, "idle_terminates": env.idle_terminates,
                "item_order": env.item_order},
        "steps": int(last.get("env_steps") or meta["algorithm"]["total_steps"]),
        "seed": meta["seed"], "algorithm": meta["algorithm"], "tables": ALL[name][0],
        "command": " ".join(command),
        "train_eval": {k: float(last[k]) for k in ("eval_reward", "eval_energy", "eval_rpe") if last.get(k)},
    }
    return pretrained.save(os.path.join(out, name), learned.params, metadata)


def main(argv=None) -> int:
    from jaxdc.cli.args import positive_int
    from jaxdc.pretrained import ASSETS

    p = argparse.ArgumentParser(prog="python -m train.ship", description=__doc__.split("\n")[0])
    p.add_argument("--only", nargs="+", choices=sorted(EVERY), default=None,
                   help=f"names to regenerate (default: {', '.join(SHIPPED)})")
    p.add_argument("--steps", type=positive_int("--steps"), default=1_000_000,
                   help="environment steps per run (thesis: 1M; enn_single_item and enn_long have their own)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--runs", default=os.path.join("runs", "ship"), help="folder of the run folders")
    p.add_argument("--out", default=os.path.join(ASSETS, "dcp"), help="where the parameter files go")
    p.add_argument("--jobs", type=int, default=2, help="trainings at a time")
    p.add_argument("--export-only", action="store_true", help="do not train; export finished runs")
    args = p.parse_args(argv)
    if args.steps < 1:
        p.error(f"--steps must be >= 1, got {args.steps}")
    if args.jobs < 1:
        p.error(f"--jobs must be >= 1, got {args.jobs}")
    names = args.only or list(SHIPPED)
    if args.export_only and any(n in DCG_STRONG for n in names):
        p.error(f"--export-only: {', '.join(n for n in names if n in DCG_STRONG)} are written by train.dcg --ship; "
                "train them (a finished run folder is resumed)")
    commands = {n: train_command(n, args.steps, args.seed, args.runs) for n in names}
    t0 = time.perf_counter()
    if not args.export_only:
        pending, running, failed = list(names), {}, []
        os.makedirs(args.runs, exist_ok=True)
        while pending or running:
            while pending and len(running) < args.jobs:
                n = pending.pop(0)
                cmd = [sys.executable] + commands[n][1:]
                if os.path.isdir(os.path.join(args.runs, n, "checkpoints")):
                    cmd.append("--resume")
                log = open(os.path.join(args.runs, f"{n}.log"), "w")
                print(f"training {n}: {' '.join(commands[n])}", file=sys.stderr)
                running[n] = (subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT), log)
            time.sleep(5)
            for n, (proc, log) in list(running.items()):
                if proc.poll() is not None:
                    log.close()
                    del running[n]
                    print(f"  {n}: exit {proc.returncode} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
                    if proc.returncode != 0:
                        failed.append(n)
        if failed:
            print(f"error: training failed for {failed}; see {args.runs}/<name>.log", file=sys.stderr)
            return 1
    for n in names:
        if n in DCG_STRONG:  # train.dcg --ship wrote it
            continue
        try:
            path = export(n, os.path.join(args.runs, n), commands[n], args.out)
        except ValueError as e:
            print(f"error: {n}: {e}", file=sys.stderr)
            return 1
        print(f"exported {path}", file=sys.stderr)
    print(f"done in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
