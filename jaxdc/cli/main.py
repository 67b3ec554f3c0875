"""The ``jaxdc`` command: one console script for every program, ``jaxdc <group> <program> [flags]``.

``jaxdc eval dcp --table 4.3`` is ``python -m eval.dcp --table 4.3`` from a checkout, and so on for
``eval dcg|drp|report`` and ``train dcp|dcg|ship``; ``python -m jaxdc ...`` is the same command.
Each program's own ``--help`` lists its flags.
"""

from __future__ import annotations

import importlib
import sys

from jaxdc.cli.runner import EXIT_USAGE, guard_process, run

#: (group, program) -> the module whose ``main(argv)`` runs it, and what it does.
PROGRAMS = {
    ("eval", "dcp"): ("jaxdc.cli.eval_dcp", "DCP tables 4.1, 4.3-4.10 and single policies (chapter 4)"),
    ("eval", "dcg"): ("jaxdc.cli.eval_dcg", "DCG collectors, figures 5.6-5.19, renders, exact optima (chapter 5)"),
    ("eval", "drp"): ("jaxdc.cli.eval_drp", "DRP plans, figures 3.1-3.5 and optimality gaps (chapter 3)"),
    ("eval", "report"): ("jaxdc.cli.eval_report", "docs/results.md from the stored results"),
    ("train", "dcp"): ("jaxdc.cli.train_dcp", "train ENN, EQN, the linear learner and the CNN on the DCP"),
    ("train", "dcg"): ("jaxdc.cli.train_dcg", "train VNN, IMNN, EMNN and OMN+CoNN on the DCG"),
    ("train", "ship"): ("jaxdc.cli.train_ship", "retrain the shipped networks"),
}


def usage() -> str:
    lines = ["usage: jaxdc <group> <program> [flags]   (jaxdc <group> <program> --help for the flags)", ""]
    lines += [f"  jaxdc {g + ' ' + p:13s} {what}" for (g, p), (_, what) in PROGRAMS.items()]
    return "\n".join(lines)


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(usage())
        return 0 if argv else EXIT_USAGE
    key = tuple(argv[:2])
    if key not in PROGRAMS:
        print(usage(), file=sys.stderr)
        print(f"\njaxdc: error: unknown program {' '.join(argv[:2])!r}", file=sys.stderr)
        return EXIT_USAGE
    name = PROGRAMS[key][0]
    # the import runs inside run() too, so that a Ctrl-C while the libraries load exits 130 cleanly
    return run(lambda rest: importlib.import_module(name).main(rest), f"jaxdc {key[0]} {key[1]}", argv[2:])


def console() -> None:
    """The ``jaxdc`` console script (under the watchdog of :func:`jaxdc.cli.runner.stop_after_signal`)."""
    guard_process("jaxdc", main)


if __name__ == "__main__":
    console()
