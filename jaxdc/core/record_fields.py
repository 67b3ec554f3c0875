"""Checking the fields of a stored JSON record as it is read: a missing or malformed field is a ``ValueError`` that
names the file and the field's key path (``results/x.json: rows[3].builder is missing``).

Every reader of stored results (the DRP experiments, the DCG evaluation cache and figure files, the results
page's inputs) checks what it reads with :class:`Fields`, so that a damaged file is refused with one line
instead of a traceback, and never drawn or summarised as if it were sound.
"""

from __future__ import annotations

import math
import re
from collections.abc import Collection
from typing import Any

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def key_path(at: str, key: Any) -> str:
    """``at`` followed by ``key``: ``rows[3]`` for an index, ``rows[3].builder`` for a name, ``results['VNN a']``
    for any other key."""
    if isinstance(key, int):
        return f"{at}[{key}]"
    if _NAME.fullmatch(str(key)):
        return f"{at}.{key}" if at else str(key)
    return f"{at}[{str(key)!r}]"


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class Fields:
    """The checks of one stored file ``file``; a failed check raises ``ValueError`` naming the file and the key
    path, followed by ``hint`` (e.g. ``"delete it or pass --force"``)."""

    def __init__(self, file: str, hint: str = "") -> None:
        self.file = file
        self.hint = hint

    def error(self, at: str, problem: str) -> ValueError:
        """The ``ValueError`` of ``at`` (a key path; ``""``: the whole file) having ``problem``."""
        tail = f"; {self.hint}" if self.hint else ""
        return ValueError(f"{self.file}: {at + ' ' if at else ''}{problem}{tail}")

    def obj(self, value: Any, at: str = "") -> dict:
        """``value`` if it is a JSON object."""
        if not isinstance(value, dict):
            raise self.error(at or "the file", f"must be a JSON object, got {_short(value)}"
                             if at else "must hold a JSON object")
        return value

    def items(self, value: Any, at: str) -> list:
        """``value`` if it is a JSON array."""
        if not isinstance(value, list):
            raise self.error(at, f"must be a list, got {_short(value)}")
        return value

    def get(self, record: dict, key: str, at: str = "") -> Any:
        """``record[key]`` (``record`` is the object at ``at``); missing: an error."""
        if key not in record:
            raise self.error(key_path(at, key), "is missing")
        return record[key]

    def number(self, value: Any, at: str, *, optional: bool = False, integer: bool = False,
               minimum: float | None = None) -> Any:
        """``value`` if it is a finite number (an integer when ``integer``; at least ``minimum``); ``None`` too
        when ``optional``."""
        if value is None and optional:
            return None
        kind = "an integer" if integer else "a number"
        ok = (isinstance(value, int) if integer else isinstance(value, (int, float))) and not isinstance(value, bool)
        if not ok or not math.isfinite(value):
            raise self.error(at, f"must be {kind}{' or null' if optional else ''}, got {_short(value)}")
        if minimum is not None and value < minimum:
            raise self.error(at, f"must be at least {minimum}, got {_short(value)}")
        return value

    def text(self, value: Any, at: str, *, optional: bool = False,
             choices: Collection[str] | None = None) -> str | None:
        """``value`` if it is a string (one of ``choices`` when given); ``None`` too when ``optional``."""
        if value is None and optional:
            return None
        if not isinstance(value, str):
            raise self.error(at, f"must be a string{' or null' if optional else ''}, got {_short(value)}")
        if choices is not None and value not in choices:
            raise self.error(at, f"must be one of {', '.join(map(repr, choices))}, got {_short(value)}")
        return value

    def flag(self, value: Any, at: str) -> bool:
        """``value`` if it is ``true`` or ``false``."""
        if not isinstance(value, bool):
            raise self.error(at, f"must be true or false, got {_short(value)}")
        return value

    # -- the same checks on a field of an object --------------------------------------------------------------
    def get_obj(self, record: dict, key: str, at: str = "", *, optional: bool = False) -> dict | None:
        value = record.get(key) if optional else self.get(record, key, at)
        return None if value is None and optional else self.obj(value, key_path(at, key))

    def get_items(self, record: dict, key: str, at: str = "") -> list:
        return self.items(self.get(record, key, at), key_path(at, key))

    def get_number(self, record: dict, key: str, at: str = "", *, optional: bool = False, absent: bool = False,
                   **kw: Any) -> Any:
        """``record[key]`` checked by :meth:`number`; ``absent``: the key may be left out (``None``)."""
        if absent and key not in record:
            return None
        return self.number(self.get(record, key, at), key_path(at, key), optional=optional, **kw)

    def get_text(self, record: dict, key: str, at: str = "", *, optional: bool = False, absent: bool = False,
                 **kw: Any) -> str | None:
        if absent and key not in record:
            return None
        return self.text(self.get(record, key, at), key_path(at, key), optional=optional, **kw)
