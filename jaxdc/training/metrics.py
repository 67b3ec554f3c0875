"""Where a run's metrics go: one CSV row per evaluation (written atomically) and, optionally, TensorBoard."""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from typing import Any

from jaxdc.io import atomic_write


def read_rows(path: str, max_updates: int) -> list[dict]:
    """The CSV rows of ``path`` up to update ``max_updates`` (a resumed run drops rows past its checkpoint)."""
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return [r for r in csv.DictReader(f) if int(r["updates"]) <= max_updates]


def write_rows(path: str, rows: list[dict], fields: Sequence[str]) -> None:
    """Write ``rows`` with the columns ``fields`` to ``path`` atomically."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, restval="", extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)
    atomic_write(path, buf.getvalue())


def tensorboard_writer(folder: str | None) -> Any:
    """A tensorboardX ``SummaryWriter`` into ``folder`` (``None``: only check the import), or a clear error
    naming the extra to install."""
    try:
        from tensorboardX import SummaryWriter
    except ImportError:
        raise ValueError("--tensorboard needs tensorboardX: pip install 'jaxdc[tb]' (or tensorboardX)") from None
    return None if folder is None else SummaryWriter(folder)
