"""Where a result came from: the versions, the commit, the device and the command line.

Every result JSON that jaxdc writes carries :func:`provenance` under the key
``"provenance"``, so a number can be traced to the code and machine that made it.
"""

from __future__ import annotations

import functools
import os
import platform
import shlex
import subprocess
import sys

from jaxdc._version import __version__


@functools.lru_cache(maxsize=1)
def git_commit() -> dict | None:
    """``{"commit", "dirty"}`` of the git checkout jaxdc runs from; ``None`` for an installed package."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    if not os.path.exists(os.path.join(root, ".git")):
        return None
    try:
        commit = subprocess.run(["git", "-C", root, "rev-parse", "HEAD"], capture_output=True, text=True,
                                timeout=10, check=True).stdout.strip()
        status = subprocess.run(["git", "-C", root, "status", "--porcelain", "--untracked-files=no"],
                                capture_output=True, text=True, timeout=10, check=True).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": commit, "dirty": bool(status.strip())}


def provenance(argv: list[str] | None = None) -> dict:
    """The jaxdc, jax and jaxlib versions, Python, the git commit (when run from a checkout), the device and the
    command line (``argv``, default ``sys.argv``)."""
    import jax
    import jaxlib

    device = jax.devices()[0]
    return {
        "jaxdc_version": __version__,
        "jax_version": jax.__version__,
        "jaxlib_version": jaxlib.__version__,
        "python_version": platform.python_version(),
        "git": git_commit(),
        "device": {"platform": device.platform, "kind": device.device_kind, "count": jax.device_count()},
        "command": shlex.join(sys.argv if argv is None else argv),
    }
