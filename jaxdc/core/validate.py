"""Checks of whole-number arguments, shared by every constructor and function that validates its input.

Python's ``bool`` is an ``int``, so ``True`` would pass a plain ``isinstance``
check as ``1``; these helpers refuse it. Validation happens outside jit, on
Python and NumPy values (command-line input is checked by :mod:`jaxdc.cli.args`).
"""

from __future__ import annotations

import numpy as np


def is_int(value, numpy: bool = True) -> bool:
    """Whether ``value`` is an ``int`` (with ``numpy``, also a NumPy integer), and not a ``bool``."""
    return not isinstance(value, bool) and isinstance(value, (int, np.integer) if numpy else int)


def check_int(name: str, value, low: int) -> int:
    """``int(value)`` for an int ``>= low``: ``TypeError`` if it is no int, ``ValueError`` if it is below ``low``."""
    if not is_int(value):
        raise TypeError(f"{name} must be an int >= {low}, got {value!r}")
    if value < low:
        raise ValueError(f"{name} must be >= {low}, got {value}")
    return int(value)


def check_positive_int(name: str, value, numpy: bool = True) -> int:
    """``int(value)`` for an int ``>= 1`` (a NumPy integer too, unless ``numpy=False``); else ``ValueError``."""
    if not is_int(value, numpy) or value < 1:
        raise ValueError(f"{name} must be an int >= 1, got {value!r}")
    return int(value)
