"""Regenerate ``docs/results.md`` from the results folder.

    python -m eval.dcp --table 4.3        # (and the other tables) fill results/dcp/
    python -m eval.dcg figure all         # results/dcg/figure_*.md and docs/img/dcg_*.png
    python benchmarks/train_throughput.py # results/benchmarks/
    python -m eval.report                 # writes docs/results.md

The page is built by :func:`jaxdc.report.build_page`: the DCP tables with
their commands and ``Δ/SE`` columns, the notes, the DCG figures and the
benchmark tables as their commands wrote them.

``--notes`` defaults to ``docs/results_notes.md`` when that file exists (else
no notes); a ``--notes FILE`` that does not exist is an error, and
``--notes none`` leaves the notes out. ``--out`` is checked before the page is
built; a missing or damaged results file is named in one ``error:`` line (exit
status 2), and Ctrl-C exits 130 leaving the previous page.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys

from jaxdc.io import atomic_write, check_output_path
from jaxdc.report import build_page


PROG = "python -m eval.report"
#: The notes appended when ``--notes`` is not given (only if the file exists).
DEFAULT_NOTES = os.path.join("docs", "results_notes.md")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    p.add_argument("--results", default="results", help="results folder (default results/)")
    p.add_argument("--notes", default=None,
                   help=f"hand-written analysis appended to the page (default {DEFAULT_NOTES} if it exists; "
                        "'none': no notes)")
    p.add_argument("--out", default=os.path.join("docs", "results.md"))
    return p


@dataclasses.dataclass(frozen=True)
class ReportSettings:
    """Where the page's inputs are and where it goes."""

    results: str  # the results folder
    notes: str | None  # the hand-written notes (None: none)
    out: str  # the page


def settle(args) -> ReportSettings:
    """The settings of the parsed arguments; ``ValueError`` for a missing ``--notes`` file or an unwritable
    ``--out``."""
    if args.notes is None:
        notes = DEFAULT_NOTES if os.path.isfile(DEFAULT_NOTES) else None
    elif args.notes.lower() == "none":
        notes = None
    elif not os.path.isfile(args.notes):
        raise ValueError(f"--notes {args.notes!r}: no such file (pass --notes none for no notes)")
    else:
        notes = args.notes
    if os.path.exists(args.results) and not os.path.isdir(args.results):
        raise ValueError(f"--results {args.results!r} is a file, not a folder")
    check_output_path(args.out, "--out")
    return ReportSettings(results=args.results, notes=notes, out=args.out)


def main(argv=None) -> int:
    """Write the page; the exit status (2 with one ``error:`` line for a bad flag or a missing or damaged input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        settings = settle(args)
        page = build_page(settings.results, settings.notes, os.path.dirname(os.path.abspath(settings.out)))
    except (FileNotFoundError, ValueError) as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    atomic_write(settings.out, page)
    print(f"wrote {settings.out}", file=sys.stderr)
    return 0
