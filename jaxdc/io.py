"""Atomic file output: results are written to a temporary file, then renamed.

A run killed half-way (Ctrl-C included) never leaves a half-written result.
"""

from __future__ import annotations

import json
import os
import tempfile


def atomic_write(path, data: bytes | str) -> str:
    """Write ``data`` to ``path`` atomically (same-directory temp file, then ``os.replace``)."""
    path = os.fspath(path)
    folder = os.path.dirname(path) or "."
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=os.path.basename(path))
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def atomic_write_json(path, obj) -> str:
    """``atomic_write`` of ``obj`` as indented JSON."""
    return atomic_write(path, json.dumps(obj, indent=2, sort_keys=False) + "\n")
