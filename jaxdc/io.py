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
        # mkstemp creates 0600; give the result the mode open() would (0666 minus the umask).
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_json(path, obj) -> str:
    """``atomic_write`` of ``obj`` as indented JSON."""
    return atomic_write(path, json.dumps(obj, indent=2, sort_keys=False) + "\n")


def enable_compilation_cache(path: str | None = None) -> None:
    """Turn on JAX's persistent compilation cache (default ``~/.cache/jaxdc/xla``).

    The command-line tools call this so that a second run skips most of the
    XLA compile time. Set ``JAXDC_NO_CACHE=1`` to turn it off.
    """
    if os.environ.get("JAXDC_NO_CACHE"):
        return
    import jax

    path = path or os.path.join(os.path.expanduser("~"), ".cache", "jaxdc", "xla")
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
