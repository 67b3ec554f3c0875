"""Checks of numeric arguments, shared by every constructor, function and command line that validates input.

Python's ``bool`` is an ``int``, so ``True`` would pass a plain ``isinstance``
check as ``1``; these helpers refuse it. Every error names the parameter, the
value and the allowed range. Validation happens outside jit, on Python and
NumPy values (the argparse types of :mod:`jaxdc.cli.args` call these helpers).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

#: The largest value a jaxdc int32 counter (a step cap, an episode count on the device) may hold.
INT32_MAX = 2**31 - 1
#: Seeds map one-to-one onto JAX keys only in ``0 .. 2**32 - 1`` (``PRNGKey`` keeps 32 bits without x64).
SEED_MAX = 2**32 - 1
#: The largest finite float32.
FLOAT32_MAX = float(np.finfo(np.float32).max)


def check_choice(name: str, value, choices):
    """``value`` if it is one of ``choices``, else a ``ValueError`` naming ``name`` and the choices as given
    (``"builder must be one of ('gi', ...), got 'xx'"``): the one check of a setting with a fixed set of values."""
    if value not in tuple(choices):
        raise ValueError(f"{name} must be one of {choices}, got {value!r}")
    return value


def is_int(value, numpy: bool = True) -> bool:
    """Whether ``value`` is an ``int`` (with ``numpy``, also a NumPy integer), and not a ``bool``."""
    return not isinstance(value, bool) and isinstance(value, (int, np.integer) if numpy else int)


def _range_text(low, high) -> str:
    if high is None:
        return f">= {low}"
    return f"in [{low}, {high}]"


def check_int(name: str, value, low: int, high: int | None = None) -> int:
    """``int(value)`` for an int in ``[low, high]`` (``high=None``: no upper bound).

    ``TypeError`` if it is no int (a ``bool`` included), ``ValueError`` if it is out of range.
    """
    if not is_int(value):
        raise TypeError(f"{name} must be an int {_range_text(low, high)}, got {value!r}")
    if value < low or (high is not None and value > high):
        raise ValueError(f"{name} must be {_range_text(low, high)}, got {value}")
    return int(value)


def check_positive_int(name: str, value, numpy: bool = True, high: int | None = None) -> int:
    """``int(value)`` for an int in ``[1, high]`` (a NumPy integer too, unless ``numpy=False``); else ``ValueError``."""
    if not is_int(value, numpy) or value < 1 or (high is not None and value > high):
        raise ValueError(f"{name} must be an int {_range_text(1, high)}, got {value!r}")
    return int(value)


def check_seed(name: str, value) -> int:
    """A seed: an int in ``[0, SEED_MAX]`` (larger ones would alias onto the same JAX key)."""
    return check_int(name, value, 0, SEED_MAX)


def check_float(name: str, value, low: float | None = None, high: float | None = None, *,
                low_open: bool = False, allow_inf: bool = False, float32: bool = True) -> float:
    """``float(value)`` for a real number in range; NaN always refused.

    ``low``/``high`` bound it (``low_open``: ``value > low`` instead of ``>=``);
    ``allow_inf`` admits ``+inf`` (a finite ``high`` still bounds the finite
    values); ``float32`` refuses finite values that would overflow to inf in
    float32. ``TypeError`` for a non-number (``bool`` included), ``ValueError``
    otherwise; the message names the parameter, the value and the range.
    """
    rng = _float_range_text(low, high, low_open, allow_inf)
    v = _as_real(value)
    if v is None:
        raise TypeError(f"{name} must be a number {rng}, got {value!r}")
    if math.isnan(v):
        raise ValueError(f"{name} must be {rng}, got NaN")
    if math.isinf(v):
        if not (allow_inf and v > 0):
            bounded = low is not None or high is not None
            raise ValueError(f"{name} must be {'a finite number ' if bounded and not allow_inf else ''}{rng}, "
                             f"got {v}")
        return v
    if (low is not None and (v <= low if low_open else v < low)) or (high is not None and v > high):
        raise ValueError(f"{name} must be {rng}, got {value_text(v)}")
    if float32 and abs(v) > FLOAT32_MAX:
        raise ValueError(f"{name} must be {rng} and fit in float32 (|x| <= {FLOAT32_MAX:.4g}), got {value_text(v)}")
    return v


def value_text(v: float) -> str:
    """A refused value as a message shows it: short (``%g``) when that reads back as ``v``, else in full
    (``repr``), so that ``1.0000001`` never reads as ``1``."""
    short = f"{v:g}"
    try:
        return short if float(short) == float(v) else repr(float(v))
    except (TypeError, ValueError, OverflowError):
        return repr(v)


def _as_real(value) -> float | None:
    """``float(value)`` for a real scalar (Python, NumPy or a 0-d array); ``None`` for a bool, text or anything else."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        return None
    if isinstance(value, numbers.Real):
        return float(value)
    dtype = getattr(value, "dtype", None)
    if dtype is not None and np.ndim(value) == 0 and np.issubdtype(dtype, np.number) \
            and not np.issubdtype(dtype, np.complexfloating):
        return float(value)
    return None


def _float_range_text(low, high, low_open, allow_inf) -> str:
    parts = []
    if low is not None:
        parts.append(f"{'>' if low_open else '>='} {low:.10g}")
    if high is not None:
        parts.append(f"<= {high:.10g}")
    if not parts:
        return "a finite number or +inf" if allow_inf else "a finite number"
    return " and ".join(parts) + (" (or inf)" if allow_inf else "")


def check_bool(name: str, value) -> bool:
    """``value`` if it is a ``bool`` (or a NumPy bool), else a ``TypeError`` naming ``name`` and the value."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool (True or False), got {value!r}")
    return bool(value)
