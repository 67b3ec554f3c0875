"""Regenerate ``docs/results.md`` from the results folder.

    python -m eval.dcp --table 4.3        # (and the other tables) fill results/dcp/
    python -m eval.dcg figure all         # results/dcg/figure_*.md and docs/img/dcg_*.png
    python benchmarks/train_throughput.py # results/benchmarks/
    python -m eval.report                 # writes docs/results.md

The page is built by :func:`jaxdc.report.build_page`: the DCP tables with
their commands and ``Δ/SE`` columns, the notes, the DCG figures and the
benchmark tables as their commands wrote them.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys

from jaxdc.io import atomic_write
from jaxdc.report import build_page


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m eval.report", description=__doc__.split("\n\n")[0])
    p.add_argument("--results", default="results", help="results folder (default results/)")
    p.add_argument("--notes", default=os.path.join("docs", "results_notes.md"),
                   help="hand-written analysis appended to the page")
    p.add_argument("--out", default=os.path.join("docs", "results.md"))
    return p


@dataclasses.dataclass(frozen=True)
class ReportSettings:
    """Where the page's inputs are and where it goes."""

    results: str  # the results folder
    notes: str | None  # the hand-written notes (skipped when the file does not exist)
    out: str  # the page


def settle(args) -> ReportSettings:
    """The settings of the parsed arguments."""
    return ReportSettings(results=args.results, notes=args.notes, out=args.out)


def main(argv=None) -> int:
    settings = settle(build_parser().parse_args(argv))
    try:
        page = build_page(settings.results, settings.notes, os.path.dirname(os.path.abspath(settings.out)))
    except FileNotFoundError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    atomic_write(settings.out, page)
    print(f"wrote {settings.out}", file=sys.stderr)
    return 0
