"""A custom risk map from a file (the ``N x N`` per-cell risks of section 4.3, saved as ``.npy`` or JSON)."""

from __future__ import annotations

import json
import os

import numpy as np

from jaxdc.core import grid


def load_risk_map(path: str, name: str = "risk map") -> np.ndarray:
    """The validated risk map stored at ``path`` (``.npy``, else a JSON nested list).

    A missing file, an unreadable one or a map that :func:`jaxdc.core.grid.validate_risk_map`
    rejects raises a ``ValueError`` that starts with ``name`` (a command line passes its flag).
    """
    if not os.path.exists(path):
        raise ValueError(f"{name}: no such file {path!r}")
    try:
        if path.endswith(".npy"):
            arr = np.load(path)
        else:
            with open(path) as f:
                arr = np.asarray(json.load(f), dtype=np.float32)
    except (ValueError, OSError) as e:
        raise ValueError(f"{name}: cannot read {path!r} as .npy or JSON: {e}") from None
    try:
        return grid.validate_risk_map(arr)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} {path!r}: {e}") from None
