"""Regenerate ``docs/results.md`` from the results folder.

    python -m eval.dcp --table 4.3        # (and the other tables) fill results/dcp/
    python -m eval.dcg figure all         # results/dcg/figure_*.md and docs/img/dcg_*.png
    python benchmarks/train_throughput.py # results/benchmarks/
    python -m eval.report                 # writes docs/results.md

The page is built by :func:`jaxdc.report.build_page`: the DCP tables with
their commands and ``Δ/SE`` columns, the notes, the DCG figures and the
benchmark tables as their commands wrote them.

``--notes`` defaults to ``docs/results_notes.md`` and ``--dcg-notes`` (the
notes that end the DCG section) to ``docs/results_notes_dcg.md``, each when
that file exists (else no notes); a FILE that does not exist is an error,
and ``none`` leaves the notes out. ``--out`` is checked before the page is
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
from jaxdc.report.page import notes_text

PROG = "python -m eval.report"
#: The notes appended when ``--notes`` is not given (only if the file exists).
DEFAULT_NOTES = os.path.join("docs", "results_notes.md")
#: The notes that end the DCG section when ``--dcg-notes`` is not given (only if the file exists).
DEFAULT_DCG_NOTES = os.path.join("docs", "results_notes_dcg.md")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    p.add_argument("--results", default="results", help="results folder (default results/)")
    p.add_argument("--notes", default=None,
                   help=f"hand-written analysis appended to the page (default {DEFAULT_NOTES} if it exists; "
                        "'none': no notes)")
    p.add_argument("--dcg-notes", default=None,
                   help=f"hand-written notes ending the DCG section (default {DEFAULT_DCG_NOTES} if it exists; "
                        "'none': no notes)")
    p.add_argument("--out", default=os.path.join("docs", "results.md"))
    return p


@dataclasses.dataclass(frozen=True)
class ReportSettings:
    """Where the page's inputs are and where it goes."""

    results: str  # the results folder
    notes: str | None  # the hand-written notes (None: none)
    dcg_notes: str | None  # the notes ending the DCG section (None: none)
    out: str  # the page


def _notes(value: str | None, default: str, flag: str) -> str | None:
    """A notes file: ``default`` if it exists when ``value`` is ``None``, none for ``'none'``; ``ValueError`` naming
    ``flag`` for a file that does not exist, a folder, or a file that is not UTF-8 text."""
    if value is None:
        return default if os.path.isfile(default) else None
    if value.lower() == "none":
        return None
    notes_text(flag, value, f"pass {flag} none for no notes")  # checked now, before the results are read
    return value


def settle(args) -> ReportSettings:
    """The settings of the parsed arguments; ``ValueError`` for a missing ``--notes`` file or an unwritable
    ``--out``."""
    notes = _notes(args.notes, DEFAULT_NOTES, "--notes")
    dcg_notes = _notes(args.dcg_notes, DEFAULT_DCG_NOTES, "--dcg-notes")
    if os.path.exists(args.results) and not os.path.isdir(args.results):
        raise ValueError(f"--results {args.results!r} is a file, not a folder")
    check_output_path(args.out, "--out", {"--notes": notes, "--dcg-notes": dcg_notes, "--results": args.results})
    return ReportSettings(results=args.results, notes=notes, dcg_notes=dcg_notes, out=args.out)


def main(argv=None) -> int:
    """Write the page; the exit status (2 with one ``error:`` line for a bad flag or a missing or damaged input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        settings = settle(args)
        page = build_page(settings.results, settings.notes, os.path.dirname(os.path.abspath(settings.out)),
                          settings.dcg_notes)
    except (FileNotFoundError, ValueError) as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    atomic_write(settings.out, page)
    print(f"wrote {settings.out}", file=sys.stderr)
    return 0
