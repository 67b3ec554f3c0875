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
import os
import sys
import time

from jaxdc import pretrained
from jaxdc.cli.args import positive_int, seed
from jaxdc.io import check_output_folder
from jaxdc.pretrained import ASSETS
from jaxdc.training.ship import EVERY, SHIPPED, export_metadata, failure_line, train_all, train_command


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m train.ship", description=__doc__.split("\n")[0])
    p.add_argument("--only", nargs="+", choices=sorted(EVERY), default=None,
                   help=f"names to regenerate (default: {', '.join(SHIPPED)})")
    p.add_argument("--steps", type=positive_int("--steps"), default=1_000_000,
                   help="environment steps per run (thesis: 1M; enn_single_item and enn_long have their own)")
    p.add_argument("--seed", type=seed("--seed"), default=0)
    p.add_argument("--runs", default=os.path.join("runs", "ship"), help="folder of the run folders")
    p.add_argument("--out", default=os.path.join(ASSETS, "dcp"), help="where the parameter files go")
    p.add_argument("--jobs", type=positive_int("--jobs"), default=2, help="trainings at a time")
    p.add_argument("--export-only", action="store_true", help="do not train; export finished runs")
    return p


def main(argv=None) -> int:
    """Train and export; the exit status. The output folders are checked before any work; a failed training is
    exit 1 with its log's error line (e.g. a run folder in use by another run: the folder and the process); every
    export is checked (:func:`jaxdc.training.ship.export_metadata`: the run's ``metrics.csv`` and the metadata, as
    the loader checks them) before any file is written, a refusal exit 2 naming the file, the line and the column;
    Ctrl-C stops the child trainings (none is left running) and exits 130 through :func:`jaxdc.cli.runner.run`."""
    p = build_parser()
    args = p.parse_args(argv)
    names = args.only or list(SHIPPED)
    dcg_names = [n for n in names if EVERY[n].problem == "dcg"]
    if args.export_only and dcg_names:
        p.error(f"--export-only: {', '.join(dcg_names)} are written by train.dcg --ship; "
                "train them (a finished run folder is resumed)")
    try:
        exported = [n for n in names if EVERY[n].problem != "dcg"]
        check_output_folder(args.out, "--out", files=[f"{n}.{ext}" for n in exported for ext in ("msgpack", "json")],
                            inputs={"--runs": [os.path.join(args.runs, n, f) for n in exported
                                               for f in ("checkpoints", "config.json", "metrics.csv")]})
        if not args.export_only:
            check_output_folder(args.runs, "--runs")
    except ValueError as e:
        p.error(str(e))
    commands = {n: train_command(n, args.steps, args.seed, args.runs) for n in names}
    t0 = time.perf_counter()
    if not args.export_only:
        failed = train_all(names, commands, args.runs, args.jobs)
        if failed:
            why = "; ".join(f"{n}: {line}" for n in failed if (line := failure_line(args.runs, n)) is not None)
            print(f"error: training failed for {failed}{f' ({why})' if why else ''}; see {args.runs}/<name>.log",
                  file=sys.stderr)
            return 1
    exports = {}
    for n in names:  # every export is checked before any file is written
        if n in dcg_names:  # train.dcg --ship wrote it
            continue
        try:
            exports[n] = export_metadata(n, os.path.join(args.runs, n), commands[n])
        except ValueError as e:
            print(f"python -m train.ship: error: {n}: {e}", file=sys.stderr)
            return 2
    for n, (params, metadata) in exports.items():
        try:
            path = pretrained.save(os.path.join(args.out, n), params, metadata)
        except ValueError as e:
            print(f"python -m train.ship: error: {n}: {e}", file=sys.stderr)
            return 2
        print(f"exported {path}", file=sys.stderr)
    print(f"done in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0
