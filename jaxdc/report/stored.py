"""Reading the stored results behind the results page (``results/``): strict JSON, a damaged file named.

A DCP table file is checked field by field as it is read (:func:`check_dcp_table`): a missing or malformed field
is a ``ValueError`` naming the file and the key (``table_4.3.json: ours.safe_reward.reward.mean must be a number or
null, got 'abc'``), never a row silently left out of the page or the scorecard. A ``null`` statistic is an
undefined one (shown as a dash); anything else that is not a number is damage.
"""

from __future__ import annotations

import contextlib
import glob
import os
import re

from jaxdc import io
from jaxdc.core.record_fields import Fields, key_path

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


def read_text(path: str, name: str | None = None, hint: str = "rerun the command that wrote it") -> str:
    """The UTF-8 text of the file ``path``; a ``ValueError`` naming it (as ``name``, default the path) and ``hint``
    when it cannot be read as text."""
    name, tail = name or path, f"; {hint}" if hint else ""
    try:
        with open(path, encoding="utf-8") as f:
            return f.read()
    except UnicodeDecodeError as e:
        raise ValueError(f"{name}: not a UTF-8 text file (byte {e.start} cannot be decoded){tail}") from None
    except OSError as e:
        raise ValueError(f"{name}: cannot read it ({e.strerror or e}){tail}") from None


def fields(path: str, command: str) -> Fields:
    """The field checks of a file at ``path`` written by ``command`` (a damaged field: rerun it)."""
    return Fields(path, f"rerun {command} to write it again")


@contextlib.contextmanager
def reading(path: str, command: str):
    """A backstop behind the field checks: a missing or malformed field met while reading ``path`` anyway is a
    ``ValueError`` naming the file and the ``command`` that writes it (no exception repr reaches the user)."""
    try:
        yield
    except (KeyError, TypeError, IndexError, AttributeError, ZeroDivisionError):
        raise ValueError(f"{path}: not a file written by {command} (a field it needs is missing or malformed); "
                         "rerun that command") from None


def _stats(f: Fields, row: dict, at: str) -> None:
    for col in ("reward", "energy", "rpe"):
        stat = f.get_obj(row, col, at)
        where = key_path(at, col)
        f.get_number(stat, "mean", where, optional=True)
        f.get_number(stat, "sd", where, optional=True, minimum=0)


def check_dcp_table(record, path: str, command: str = "python -m eval.dcp --table") -> dict:
    """``record`` (read from ``path``, a ``table_<T>.json``) if every field the page and the scorecard read is
    sound, else a ``ValueError`` naming the file and the key: the table's names; each thesis row (six numbers or
    ``null``); each of our rows' reward, energy and RPE (``mean`` and ``sd``: a number, or ``null`` when undefined)
    and episode count; the ``optimal`` row's exact optimum; the learned and best rows (naming rows of ``ours``);
    the incr.% columns."""
    f = fields(path, command)
    f.obj(record)
    table = f.get_text(record, "table")
    m = TABLE_FILE.fullmatch(os.path.basename(path))
    if not TABLE_FILE.fullmatch(f"table_{table}.json") or (m and m.group(1) != table):
        raise f.error("table", f"{table!r} is not the table of the file's name")
    f.get_text(record, "caption")
    f.get_text(record, "command")
    for name, th in f.get_obj(record, "thesis").items():
        at = key_path("thesis", name)
        if len(f.items(th, at)) != 6:
            raise f.error(at, f"must hold 6 values (reward, energy, RPE: mean and SD each), got {len(th)}")
        for i, v in enumerate(th):
            f.number(v, f"{at}[{i}]", optional=True)
    ours = f.get_obj(record, "ours")
    for name, row in ours.items():
        at = key_path("ours", name)
        f.obj(row, at)
        _stats(f, row, at)
        f.get_number(row, "episodes", at, integer=True, minimum=1)  # a row of no games is no result
        if name == "optimal":
            opt = f.get_number(row, "expected_optimum", at)
            if opt <= 0:
                raise f.error(key_path(at, "expected_optimum"), f"must be positive, got {opt!r}")

    def names_a_row(rec, key, at):
        row = f.get_text(rec, key, at, absent=key == "row" and at == "learned")
        if row is not None and row not in ours:
            raise f.error(key_path(at, key), f"{row!r} is not a row of ours")

    learned = f.get_obj(record, "learned", optional=True)
    if learned is not None:
        f.get_text(learned, "net", "learned")
        f.get_text(learned, "source", "learned")
        f.get_text(learned, "command", "learned", optional=True, absent=True)
        names_a_row(learned, "row", "learned")
    best = f.get_obj(record, "best", optional=True)
    if best is not None:
        names_a_row(best, "row", "best")
        for key in ("thesis_row", "checkpoint", "differs"):
            f.get_text(best, key, "best")
        if "greedy" in best:
            f.flag(best["greedy"], "best.greedy")
    for name, cols in (f.get_obj(record, "incr", optional=True) or {}).items():
        at = key_path("incr", name)
        f.obj(cols, at)
        for col in ("reward", "energy", "rpe"):
            values = f.get_items(cols, col, at)
            if len(values) != 2:
                raise f.error(key_path(at, col), f"must hold 2 values (thesis, ours), got {len(values)}")
            for i, v in enumerate(values):
                f.number(v, f"{key_path(at, col)}[{i}]", optional=True)
    return record


def dcp_table_file(path: str) -> dict:
    """The checked record of the DCP table file ``path`` (:func:`check_dcp_table`)."""
    return check_dcp_table(read_json(path), path)


def require_fields(record, path: str, command: str, fields) -> dict:
    """``record`` if it is a JSON object with every key of ``fields``, else a ``ValueError`` naming the file, the
    missing keys and the ``command`` that writes it."""
    missing = [f for f in fields if not isinstance(record, dict) or f not in record]
    if missing:
        raise ValueError(f"{path}: not a file written by {command} (no {', '.join(map(repr, missing))}); "
                         "rerun that command")
    return record
