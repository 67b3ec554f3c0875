"""Cheap, exactly distributed random draws shared by the grid problems.

``jax.random.randint`` spends several random words and a division per draw;
resetting thousands of environments per step makes that the bottleneck. Here
one 32-bit word makes one draw by Lemire's multiply-shift,
``floor(u * n / 2**32)``, computed exactly in 32-bit arithmetic. Its bias is
at most ``n / 2**32`` per value (none when ``n`` is a power of two).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

#: The largest range ``uniform_index`` supports (the 32-bit product must not overflow).
MAX_RANGE = 65535
#: The most units one reset may drop: the item planes count them in float32, exact up to 2**24.
MAX_TOTAL_REWARD = 2**24
#: The largest magnitude of the tilt of :func:`power_law_integer` (beyond the thesis: the tilted draws of a
#: maximum energy and of an item count).
MAX_TILT = 8.0


def uniform_index(key, shape, n):
    """Integers uniform on ``[0, n)`` (``1 <= n <= 65535``, may be traced), shape ``shape``."""
    u = jax.random.bits(key, shape, jnp.uint32)
    n = jnp.asarray(n, jnp.uint32)
    hi, lo = u >> 16, u & 0xFFFF
    return ((hi * n + ((lo * n) >> 16)) >> 16).astype(jnp.int32)


def drop_units(key, units: int, cells: int, low: int = 0, count=None):
    """Drop ``units`` unit rewards uniformly on cells ``low .. cells-1`` (a multinomial).

    Returns ``(counts, first)``, both ``[cells]``: the units per cell, and the
    index of the first unit that landed on each cell (``units`` where none did),
    which is the order of the item list. ``count`` (may be traced, ``<= units``)
    keeps only the first ``count`` of the ``units`` draws: a drop of ``count``
    units with a shape fixed by ``units``.
    """
    where = low + uniform_index(key, (units,), cells - low)
    index = jnp.arange(units, dtype=jnp.int32)
    kept = jnp.ones(units, bool) if count is None else index < count
    counts = jnp.zeros(cells, jnp.float32).at[where].add(kept.astype(jnp.float32))
    first = jnp.full(cells, units, jnp.int32).at[where].min(jnp.where(kept, index, units))
    return counts, first


#: The longest mask :func:`running_count` counts with a triangular product (a 4 MiB matrix); longer: ``cumsum``.
RUNNING_COUNT_MATMUL_MAX = 1024


def running_count(mask):
    """``cumsum(mask)`` of a 1-D boolean mask as int32, as one product with a triangular matrix of ones.

    Exact (the counts are small integers, far below float32's 2**24), and on CPU much faster than
    ``jnp.cumsum`` under ``vmap``, which XLA lowers to a windowed reduction.
    """
    n = mask.shape[-1]
    if n > RUNNING_COUNT_MATMUL_MAX:  # the n x n matrix would be too large: XLA's cumsum
        return jnp.cumsum(mask, dtype=jnp.int32)
    upper = jnp.triu(jnp.ones((n, n), jnp.float32))
    return jnp.matmul(mask.astype(jnp.float32), upper, precision=jax.lax.Precision.HIGHEST).astype(jnp.int32)


def power_law_integer(key, low, high, tilt=None):
    """An integer of ``[low, high]`` (float32; may be traced; jit/vmap), the draw of a tilted training distribution
    (beyond the thesis: the maximum energy, :func:`jaxdc.core.energy.draw_max_energy`, and the item count of a DCP
    episode).

    ``tilt`` ``None``: uniformly. Otherwise a power law: ``x`` is drawn with density proportional to ``x ** -tilt``
    on ``[low, high + 1)`` (inverse CDF; ``tilt = 1`` is log-uniform) and floored, so that each integer ``E`` has
    probability proportional to the integral of ``x ** -tilt`` over ``[E, E + 1)``: a positive tilt weights the low
    integers, a negative one the high ones. ``low >= 1`` (the density is finite there); ``|tilt| <= MAX_TILT``."""
    u = jax.random.uniform(key)
    if tilt is None:
        x = jnp.floor(low + u * (high - low + 1.0))
    else:
        top = high + 1.0
        log_uniform = jnp.abs(tilt - 1.0) < 1e-6
        b = jnp.where(log_uniform, 1.0, 1.0 - tilt)  # 1 - tilt, kept away from 0 in the branch not taken
        base = jnp.maximum(low**b + u * (top**b - low**b), jnp.finfo(jnp.float32).tiny)  # > 0 after rounding
        power = base ** (1.0 / b)
        x = jnp.floor(jnp.where(log_uniform, low * (top / low) ** u, power))
    return jnp.clip(x, low, high).astype(jnp.float32)
