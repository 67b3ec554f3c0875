"""The whole results page: header, scorecard, the DCP tables, the hand-written notes, then the copied sections."""

from __future__ import annotations

import os

from jaxdc.report.copied import DCG_TITLE, copied_sections
from jaxdc.report.dcp_tables import dcp_table
from jaxdc.report.scorecard import scorecard
from jaxdc.report.stored import dcp_table_file, read_text, reading, table_files

HEADER = """# Results: the thesis against jaxdc

Every number below comes from the command printed above its table; rerun it to check.
This page is built by `python -m eval.report` from the raw results committed in `results/`, so a clean
clone rebuilds it (`tests/report/test_page.py` checks that the committed page is the rebuilt one).
The DRP figures are on [drp.md](drp.md); the readings behind the defaults are on
[ambiguities.md](ambiguities.md).

`Δ/SE` is (ours − thesis) divided by the standard error of the thesis' mean, `sd/√episodes`:
|Δ/SE| below ~3 is agreement within sampling noise. For scale, the thesis reran the navigators
for Tables 4.9 and 4.10 in the setting of Table 4.3, and its own Safe-Reward reward moved from
11.55 to 11.74 between runs (≈ 3 SE).
"""


def build_page(results_dir: str, notes_path: str | None, out_dir: str = "docs",
               dcg_notes_path: str | None = None) -> str:
    """The page: header, the scorecard (:mod:`jaxdc.report.scorecard`), the DCP tables of ``results_dir/dcp``, the
    notes at ``notes_path`` (``None``: none), the copied sections, the DCG one ending with the notes at
    ``dcg_notes_path``; links are relative to ``out_dir``. ``FileNotFoundError`` when there is no DCP table;
    ``ValueError`` naming the file (and the key) when a table file is damaged, and naming the flag when a notes
    file is missing, a folder or not UTF-8 text (:func:`notes_text`)."""
    files = table_files(results_dir)
    if not files:
        raise FileNotFoundError(
            f"no DCP tables in {results_dir}/dcp: run e.g. `python -m eval.dcp --table 4.3` first"
        )
    notes = {flag: notes_text(flag, path) for flag, path in (("--notes", notes_path),
                                                               ("--dcg-notes", dcg_notes_path))}
    parts = [HEADER, scorecard(results_dir), "## DCP (chapter 4): Tables 4.1 and 4.3-4.10, navigators and learners", ""]
    for path in files:
        table = dcp_table_file(path)
        with reading(path, "python -m eval.dcp --table"):
            parts += [dcp_table(table), ""]
    if notes["--notes"] is not None:
        parts += [notes["--notes"], ""]
    dcg_notes = {} if notes["--dcg-notes"] is None else {DCG_TITLE: notes["--dcg-notes"]}
    parts += copied_sections(results_dir, out_dir, dcg_notes)
    return "\n".join(parts)


def notes_text(flag: str, path: str | None, hint: str = "") -> str | None:
    """The text of the notes file ``path`` given as ``flag`` (``None``: none); a ``ValueError`` naming the flag (and
    ``hint``) when it is a folder, missing, or not UTF-8 text."""
    if not path:
        return None
    tail = f" ({hint})" if hint else ""
    if os.path.isdir(path):
        raise ValueError(f"{flag} {path!r} is a folder, not a notes file{tail}")
    if not os.path.isfile(path):
        raise ValueError(f"{flag} {path!r}: no such file{tail}")
    return read_text(path, f"{flag} {path!r}", hint)
