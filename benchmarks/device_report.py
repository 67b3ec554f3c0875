"""One prepared device benchmark: environment and training throughput and compile times, in one table.

Usage::

    python benchmarks/device_report.py [--json] [--small] [--batch-sizes 4096 16384 65536 262144]
                                       [--steps N] [--train-envs 1024 4096] [--train-steps N] [--repeats N]
                                       [--budget-s 540] [--games dcp dcg] [--learners a2c ppo]
                                       [--net enn] [--out-dir results/benchmarks]

Made to run once on an accelerator that a session is lent (issue 30) and to
finish in under 10 minutes on one GPU; it reuses the rows of
:mod:`benchmarks.env_throughput` and :mod:`benchmarks.train_throughput`:

* ``env``: ``jax_random`` (the DCP of Table 4.3, a uniformly random policy with
  auto-reset, vmapped, in ``lax.scan``, jitted) and ``jax_dcg_random`` (the DCG of
  section 5.5.1) at B = 4,096 .. 262,144 environments, ``--steps`` steps each, and the
  same two stepped by :func:`jaxdc.core.batched.step_batched` (``jax_batched``,
  ``jax_dcg_batched``: batch-level random numbers);
* ``train``: ENN (``--net``) on the DCP with the A2C learner of Algorithm 10 (``jaxdc enn``) and
  with the PPO-style options (``jaxdc enn ppo``, :func:`benchmarks.train_throughput.ppo_options`),
  ``t_max`` 32, updates in ``lax.scan`` (layout ``scan``), about ``--train-steps``
  environment steps per timed call, for each ``--train-envs``; ``s_per_1M`` is the time
  of one million training steps at that rate;
* every row's ``compile_s``: its first call minus a timed one.

The timings are the best of ``--repeats`` calls after the compiling one. Rows that
would start after ``--budget-s`` seconds are listed as skipped (so the script stays
within its slot). The table is written as ``device_report.{json,md}`` into ``--out-dir``
(the two land together); ``--json`` prints the JSON object on stdout. ``--small`` is a
CPU smoke setting (B = 64; 4 steps; 8 training environments; 1 repeat);
``--games`` / ``--learners`` choose the rows. Every count must be an integer >= 1 and ``--out-dir`` writable;
both are checked before any timing (a bad value exits with status 2 and one
``error:`` line).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

import jax  # noqa: E402

from benchmarks import env_throughput, train_throughput  # noqa: E402
from benchmarks.publish import publish  # noqa: E402
from jaxdc.cli.args import integer, positive_int  # noqa: E402
from jaxdc.cli.runner import run as run_cli  # noqa: E402
from jaxdc.io import check_output_folder  # noqa: E402

DEFAULT_BATCH_SIZES = (4096, 16384, 65536, 262144)
DEFAULT_STEPS = 100
DEFAULT_TRAIN_ENVS = (1024, 4096)
DEFAULT_TRAIN_STEPS = 1 << 21
#: Rows that would start later than this many seconds after the start are skipped (10 minutes, less a margin).
DEFAULT_BUDGET_S = 540.0
#: ``--small``: a CPU smoke setting.
SMALL = {"batch_sizes": [64], "steps": 4, "train_envs": [8], "train_steps": 8 * 32 * 2, "repeats": 1}
#: The environment rows: (benchmarks.env_throughput game, row name, batch-level random numbers).
GAMES = (("dcp", "jax_random", False), ("dcp", "jax_batched", True), ("dcg", "jax_dcg_random", False),
         ("dcg", "jax_dcg_batched", True))
GAME_NAMES = tuple(dict.fromkeys(g for g, _, _ in GAMES))
#: The learners: (row name suffix, PPO-style options).
LEARNERS = (("a2c", False), ("ppo", True))
NETS = ("enn", "cnn", "linear")
LAYOUT = "scan"
RESULTS_DIR = env_throughput.RESULTS_DIR


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def device_info() -> dict:
    """The devices the rows ran on."""
    d = jax.devices()
    return {"platform": d[0].platform, "device_kind": d[0].device_kind, "device_count": len(d),
            "load_average_1m": round(os.getloadavg()[0], 2), "cpu_count": os.cpu_count()}


def env_row(game: str, batch: int, steps: int, repeats: int, batched: bool = False) -> dict:
    row = env_throughput.bench_jax("random", batch, steps, repeats, game=game, batched=batched)
    return {"kind": "env", "impl": row["impl"], "batch": batch, "env_steps": row["env_steps"],
            "seconds": row["seconds"], "compile_s": row["compile_s"], "steps_per_s": row["steps_per_s"]}


def train_row(net: str, learner: str, ppo: bool, num_envs: int, chunk_steps: int, repeats: int) -> dict:
    row = train_throughput.bench_jax(net, num_envs, LAYOUT, chunk_steps, repeats, ppo=ppo)
    return {"kind": "train", "impl": f"{row['impl']} ({learner})", "batch": num_envs * train_throughput.T_MAX,
            "num_envs": num_envs, "env_steps": row["env_steps"], "seconds": row["seconds"],
            "compile_s": row["compile_s"], "steps_per_s": row["steps_per_s"], "s_per_1M": 1e6 / row["steps_per_s"]}


def plan(args: argparse.Namespace) -> list[tuple[str, tuple]]:
    """The rows in the order they run: ``(label, (function, arguments))``."""
    rows = [(f"{name} B={b}", (env_row, (game, b, args.steps, args.repeats, batched)))
            for game, name, batched in GAMES if game in args.games for b in args.batch_sizes]
    rows += [(f"{args.net} {learner} envs={n}", (train_row, (args.net, learner, ppo, n, args.train_steps,
                                                              args.repeats)))
             for learner, ppo in LEARNERS if learner in args.learners for n in args.train_envs]
    return rows


def run(args: argparse.Namespace) -> dict:
    t_start = time.perf_counter()
    rows, skipped = [], []
    for label, (fn, fn_args) in plan(args):
        if time.perf_counter() - t_start > args.budget_s:
            skipped.append(label)
            log(f"skipped (past --budget-s {args.budget_s:g}): {label}")
            continue
        row = fn(*fn_args)
        log(f"{label:>28}: {row['steps_per_s']:>16,.0f} steps/s (compile {row['compile_s']:.2f} s)")
        rows.append(row)
    return {"benchmark": "device_report", "device": device_info(), "rows": rows, "skipped": skipped,
            "settings": {"batch_sizes": args.batch_sizes, "steps": args.steps, "train_envs": args.train_envs,
                         "train_steps": args.train_steps, "repeats": args.repeats, "t_max": train_throughput.T_MAX,
                         "net": args.net, "layout": LAYOUT, "budget_s": args.budget_s, "small": args.small,
                         "games": args.games, "learners": args.learners},
            "total_s": round(time.perf_counter() - t_start, 2)}


def markdown(result: dict) -> str:
    d = result["device"]
    lines = [f"Device report: {d['device_count']} x {d['device_kind']} ({d['platform']}); load average "
             f"{d['load_average_1m']} on {d['cpu_count']} CPUs; {result['total_s']:.1f} s in all.", "",
             "| kind | row | batch | env-steps/s | compile s | s per 1M steps |",
             "|---|---|---:|---:|---:|---:|"]
    for r in result["rows"]:
        per_m = f"{r['s_per_1M']:.2f}" if "s_per_1M" in r else ""
        lines.append(f"| {r['kind']} | {r['impl']} | {r['batch']:,} | {r['steps_per_s']:,.0f} | "
                     f"{r['compile_s']:.2f} | {per_m} |")
    if result["skipped"]:
        lines += ["", "Skipped (past the time budget): " + ", ".join(result["skipped"]) + "."]
    return "\n".join(lines)


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python benchmarks/device_report.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--small", action="store_true", help="tiny CPU smoke settings (the size flags override them)")
    p.add_argument("--batch-sizes", type=positive_int("--batch-sizes"), nargs="+", default=None,
                   help=f"environment batch sizes (default {' '.join(map(str, DEFAULT_BATCH_SIZES))})")
    p.add_argument("--steps", type=positive_int("--steps"), default=None,
                   help=f"steps per environment row (default {DEFAULT_STEPS})")
    p.add_argument("--train-envs", type=positive_int("--train-envs"), nargs="+", default=None,
                   help=f"training environments (default {' '.join(map(str, DEFAULT_TRAIN_ENVS))})")
    p.add_argument("--train-steps", type=positive_int("--train-steps"), default=None,
                   help=f"environment steps per timed training call (default {DEFAULT_TRAIN_STEPS})")
    p.add_argument("--repeats", type=positive_int("--repeats"), default=None, help="timed repeats (default 3)")
    p.add_argument("--budget-s", type=integer("--budget-s", low=0), default=int(DEFAULT_BUDGET_S),
                   help="skip the rows that would start after this many seconds")
    p.add_argument("--games", nargs="+", choices=GAME_NAMES, default=list(GAME_NAMES),
                   help="the environment rows (default both)")
    p.add_argument("--learners", nargs="+", choices=[name for name, _ in LEARNERS],
                   default=[name for name, _ in LEARNERS], help="the training rows (default both)")
    p.add_argument("--net", choices=NETS, default="enn", help="the trained network (default enn)")
    p.add_argument("--out-dir", type=Path, default=RESULTS_DIR)
    args = p.parse_args(argv)
    base = SMALL if args.small else {"batch_sizes": list(DEFAULT_BATCH_SIZES), "steps": DEFAULT_STEPS,
                                     "train_envs": list(DEFAULT_TRAIN_ENVS), "train_steps": DEFAULT_TRAIN_STEPS,
                                     "repeats": 3}
    for k, v in base.items():
        if getattr(args, k) is None:
            setattr(args, k, v)
    try:
        check_output_folder(args.out_dir, "--out-dir")
        env_throughput.check_memory(args.batch_sizes)
    except (ValueError, MemoryError) as e:
        p.error(str(e))
    return args


def main(argv=None) -> dict:
    args = parse_args(argv)
    result = run(args)
    result["command"] = " ".join(["python benchmarks/device_report.py", *(sys.argv[1:] if argv is None else argv)])
    publish(args.out_dir, "device_report", result, markdown(result), args.json)
    return result


if __name__ == "__main__":
    sys.exit(run_cli(lambda argv: (main(argv), 0)[1], "python benchmarks/device_report.py"))
