"""A custom risk map from a file (the ``N x N`` per-cell risks of section 4.3, saved as ``.npy`` or JSON)."""

from __future__ import annotations

import os

import numpy as np

from jaxdc.core import grid
from jaxdc.io import read_json


def load_risk_map(path: str, name: str = "risk map") -> np.ndarray:
    """The validated risk map stored at ``path`` (``.npy``, else a JSON nested list), as float32.

    The file's values are checked as stored, before any conversion: a boolean
    array or a JSON ``true``/``false``, text, NaN or Infinity, a value outside
    ``[0, 1]``, a non-square map or a base cell with risk are refused
    (:func:`jaxdc.core.grid.validate_risk_map`). A missing file, an unreadable
    one or a refused map raises a ``ValueError`` that starts with ``name`` (a
    command line passes its flag) and names the file.
    """
    if not os.path.exists(path):
        raise ValueError(f"{name}: no such file {path!r}")
    if os.path.isdir(path):
        raise ValueError(f"{name}: {path!r} is a folder, not a .npy or JSON file")
    if not path.endswith(".npy"):
        try:
            arr = read_json(path, hint="a risk map is an N x N nested list of risks in [0, 1]")
        except ValueError as e:  # names the file; NaN and Infinity refused as strict JSON has neither
            raise ValueError(f"{name}: {e}") from None
    else:
        try:
            arr = np.load(path, allow_pickle=False)
            if not isinstance(arr, np.ndarray):
                raise ValueError("not a single array")
            if arr.dtype.kind not in "biuf":
                raise ValueError(f"{name} {path!r}: must hold real numbers, got dtype {arr.dtype}")
        except (ValueError, OSError, EOFError, UnicodeDecodeError) as e:
            if str(e).startswith(name):
                raise ValueError(str(e)) from None
            raise ValueError(f"{name}: cannot read {path!r} as .npy: {e}") from None
    try:
        return grid.validate_risk_map(arr)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} {path!r}: {e}") from None
