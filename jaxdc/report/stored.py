"""Reading the stored results behind the results page (``results/``): strict JSON, a damaged file named."""

from __future__ import annotations

import contextlib
import glob
import os
import re

from jaxdc import io

#: A DCP table's results file: ``table_<T>.json`` with ``T`` a table number (``4.3``); other names are ignored.
TABLE_FILE = re.compile(r"table_(\d+(?:\.\d+)*)\.json")


def read_json(path: str) -> dict:
    """One stored results file, strict JSON; ``ValueError`` naming the file if it is unreadable."""
    return io.read_json(path, "rerun the command that wrote it")


def table_files(results_dir: str) -> list[str]:
    """The ``table_<T>.json`` files of ``results_dir/dcp``, in table order."""
    found = []
    for path in glob.glob(os.path.join(results_dir, "dcp", "table_*.json")):
        m = TABLE_FILE.fullmatch(os.path.basename(path))
        if m:
            found.append((tuple(int(x) for x in m.group(1).split(".")), path))
    return [path for _, path in sorted(found)]


@contextlib.contextmanager
def reading(path: str, command: str):
    """Turn a missing or malformed field met while reading ``path`` into a ``ValueError`` naming the file and the
    ``command`` that writes it."""
    try:
        yield
    except (KeyError, TypeError, IndexError, AttributeError, ZeroDivisionError) as e:
        raise ValueError(f"{path}: not a file written by {command} (missing or malformed {e!r}); "
                         "rerun that command") from None


def require_fields(record, path: str, command: str, fields) -> dict:
    """``record`` if it is a JSON object with every key of ``fields``, else a ``ValueError`` naming the file, the
    missing keys and the ``command`` that writes it."""
    missing = [f for f in fields if not isinstance(record, dict) or f not in record]
    if missing:
        raise ValueError(f"{path}: not a file written by {command} (no {', '.join(map(repr, missing))}); "
                         "rerun that command")
    return record
