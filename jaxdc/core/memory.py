"""Memory estimates checked before a large allocation, so that a request too big for the machine is refused
with a message that says what to lower, instead of aborting inside XLA (``std::bad_alloc``, RESOURCE_EXHAUSTED).

:func:`available_bytes` is the memory of the default device: the allocator's
limit on an accelerator, the available host memory on the CPU. Set
``JAXDC_MEMORY_LIMIT`` (bytes, a number >= 1 such as ``8e9``) to use another limit, e.g. to share a machine;
any other value is refused with a ``ValueError`` naming the variable and the value.
"""

from __future__ import annotations

import math
import os
from typing import Any

import jax
import numpy as np


def available_bytes() -> int | None:
    """Bytes a computation may use on the default device; ``None`` if unknown."""
    env = os.environ.get("JAXDC_MEMORY_LIMIT")
    if env is not None and env.strip():
        return memory_limit(env)
    device = jax.devices()[0]
    if device.platform != "cpu":
        stats = device.memory_stats() or {}
        limit = stats.get("bytes_limit")
        if limit:
            return int(limit) - int(stats.get("bytes_in_use", 0))
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


#: The environment variable that overrides :func:`available_bytes`.
LIMIT_VARIABLE = "JAXDC_MEMORY_LIMIT"


def memory_limit(text: str) -> int:
    """The byte count of a ``JAXDC_MEMORY_LIMIT`` value: a finite number >= 1 (``"8e9"``, ``"1000000"``); else a
    ``ValueError`` naming the variable, the value and what it must be."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not math.isfinite(v) or v < 1:
        raise ValueError(f"{LIMIT_VARIABLE}={text!r} must be a number of bytes >= 1 (e.g. 8e9 for 8 GB); "
                         "unset it to use the device's memory")
    return int(v)


def tree_bytes(tree: Any) -> int:
    """Bytes of the arrays (or ``ShapeDtypeStruct``\\ s) of a pytree."""
    return sum(int(np.prod(x.shape)) * np.dtype(x.dtype).itemsize for x in jax.tree_util.tree_leaves(tree))


def check_fits(needed: int, what: str, lower: str) -> None:
    """``MemoryError`` if ``needed`` bytes exceed :func:`available_bytes`; the message names ``what`` and ``lower``."""
    limit = available_bytes()
    if limit is not None and needed > limit:
        raise MemoryError(f"{what} needs about {_gib(needed)} but {_gib(limit)} is available; lower {lower} "
                          f"(JAXDC_MEMORY_LIMIT, in bytes, sets the limit)")


def _gib(b: int) -> str:
    """``b`` bytes readably: GiB from 256 MiB, MiB from 1 MiB, then KiB, then bytes (a small size never shows as 0)."""
    if b >= 2**28:
        return f"{b / 2**30:.1f} GiB"
    if b >= 2**20:
        return f"{b / 2**20:.0f} MiB"
    if b >= 2**10:
        return f"{b / 2**10:.0f} KiB"
    return f"{int(b)} bytes"
