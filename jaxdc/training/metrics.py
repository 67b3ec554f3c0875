"""Where a run's metrics go: one CSV row per evaluation (written atomically) and, optionally, TensorBoard.

A resumed run reads its CSV back (:func:`read_rows`); a damaged one (not a
file, unreadable, no ``updates`` column, a truncated row, a value that is not
a number, updates out of order) is refused with an error naming the file,
the line and the column, never dropped: repair the file, or move it away to
start a new history at the checkpoint.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Sequence
from typing import Any

from jaxdc.checkpoint import writing
from jaxdc.io import atomic_write

#: What a damaged metrics file's error tells a resumed run to do.
RESUME_FIX = "repair it, or move it away to start a new history at the checkpoint"


def read_rows(path: str, max_updates: int) -> list[dict]:
    """The CSV rows of ``path`` up to update ``max_updates`` (a resumed run drops rows past its checkpoint); none
    if there is no file. A damaged file is a ``ValueError`` naming it, the line and the column."""
    return [row for _, row in numbered_rows(path) if int(float(row["updates"])) <= max_updates]


def numbered_rows(path: str, fix: str = RESUME_FIX) -> list[tuple[int, dict]]:
    """``(line, row)`` of every CSV row of ``path`` (its line number in the file, the header being line 1); none if
    there is no file. A damaged file (see the module docs) is a ``ValueError`` naming it, the line and the column,
    ending with ``fix`` (what to do about it)."""
    if not os.path.lexists(path):
        return []
    if not os.path.isfile(path):
        raise ValueError(f"metrics file {path} is not a file ({'a folder' if os.path.isdir(path) else 'broken'}); "
                         f"{fix}")
    try:
        with open(path, newline="", encoding="utf-8") as f:
            lines = list(csv.reader(f, strict=True))
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise ValueError(f"metrics file {path} cannot be read ({e}); {fix}") from None
    if not lines or "updates" not in lines[0] or len(set(lines[0])) != len(lines[0]) or "" in lines[0]:
        raise ValueError(f"metrics file {path}: line 1 is no header of a metrics CSV (names 'updates' once, and "
                         f"each column once); {fix}")
    header, rows, last = lines[0], [], 0
    for n, values in enumerate(lines[1:], start=2):
        if not values:
            continue
        if len(values) != len(header):
            raise ValueError(f"metrics file {path}: line {n} has {len(values)} values, the header {len(header)} "
                             f"(a truncated or damaged row); {fix}")
        row = dict(zip(header, values))
        for column, text in row.items():
            if text != "" and _number(text) is None:
                raise ValueError(f"metrics file {path}: line {n}, column {column}: {text!r} is not a number; {fix}")
        update = _number(row["updates"])
        if update is None or not math.isfinite(update) or update != int(update) or not last < update:
            raise ValueError(f"metrics file {path}: line {n}, column updates: {row['updates']!r} is not an update "
                             f"count after {last}; {fix}")
        last = int(update)
        rows.append((n, row))
    return rows


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def write_rows(path: str, rows: list[dict], fields: Sequence[str]) -> None:
    """Write ``rows`` with the columns ``fields`` to ``path`` atomically."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, restval="", extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)
    with writing(path):
        atomic_write(path, buf.getvalue())


def tensorboard_writer(folder: str | None) -> Any:
    """A tensorboardX ``SummaryWriter`` into ``folder`` (``None``: only check the import), or a clear error
    naming the extra to install."""
    try:
        from tensorboardX import SummaryWriter
    except ImportError:
        raise ValueError("--tensorboard needs tensorboardX: pip install 'jaxdc[tb]' (or tensorboardX)") from None
    return None if folder is None else SummaryWriter(folder)
