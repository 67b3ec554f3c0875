"""Observation and action spaces of the functional environments, with gymnax's semantics.

:class:`Discrete` and :class:`Box` mirror ``gymnax.environments.spaces``
(``sample(rng)``, ``contains(x)``, ``shape``, ``dtype``; ``Discrete.n``,
``Box.low``/``Box.high``) without depending on gymnax, so gymnax-style
wrappers and PureJaxRL-style loops that read ``env.observation_space(params)``
and ``env.action_space(params)`` work on jaxdc. Bounds are finite NumPy arrays
(or Python numbers): building a space starts no JAX backend.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np


class Discrete:
    """The integers ``0 .. n - 1`` (an action space); with ``shape`` (e.g. ``(k,)`` for ``k`` stacked agents)
    an array of them, each in ``0 .. n - 1``."""

    def __init__(self, num_categories: int, shape: tuple[int, ...] = ()) -> None:
        if isinstance(num_categories, bool) or not isinstance(num_categories, (int, np.integer)) \
                or num_categories < 1:
            raise ValueError(f"num_categories must be an int >= 1, got {num_categories!r}")
        self.n = int(num_categories)
        self.shape: tuple[int, ...] = tuple(int(s) for s in shape)
        self.dtype = jnp.int32

    def sample(self, rng: jax.Array) -> jax.Array:
        """A uniform random element."""
        return jax.random.randint(rng, shape=self.shape, minval=0, maxval=self.n).astype(self.dtype)

    def contains(self, x: Any) -> jax.Array:
        """Whether ``x`` is an integer in ``0 .. n - 1`` (a jittable boolean); with a ``shape``, whether ``x`` has
        it and every entry is one."""
        x = jnp.asarray(x)
        ok = jnp.logical_and(jnp.logical_and(x >= 0, x < self.n), x == jnp.round(x))
        if not self.shape:
            return ok
        return jnp.bool_(False) if x.shape != self.shape else jnp.all(ok)

    def __repr__(self) -> str:
        return f"Discrete({self.n})" if not self.shape else f"Discrete({self.n}, shape={self.shape})"


class Box:
    """Arrays of ``shape`` with every entry in ``[low, high]`` (finite bounds)."""

    def __init__(self, low: Any, high: Any, shape: tuple[int, ...], dtype: Any = jnp.float32) -> None:
        self.shape = tuple(int(s) for s in shape)
        self.low = np.broadcast_to(np.asarray(low, np.float32), self.shape).copy()
        self.high = np.broadcast_to(np.asarray(high, np.float32), self.shape).copy()
        if not (np.all(np.isfinite(self.low)) and np.all(np.isfinite(self.high))):
            raise ValueError("Box bounds must be finite")
        if np.any(self.low > self.high):
            raise ValueError("Box bounds must satisfy low <= high")
        self.dtype = dtype

    def sample(self, rng: jax.Array) -> jax.Array:
        """A uniform random array in the box."""
        return jax.random.uniform(rng, shape=self.shape, minval=self.low, maxval=self.high).astype(self.dtype)

    def contains(self, x: Any) -> jax.Array:
        """Whether ``x`` has the shape and lies in the bounds (a jittable boolean)."""
        x = jnp.asarray(x)
        if x.shape != self.shape:
            return jnp.bool_(False)
        return jnp.logical_and(jnp.all(x >= self.low), jnp.all(x <= self.high))

    def __repr__(self) -> str:
        return f"Box(low={float(self.low.min()):g}, high={float(self.high.max()):g}, shape={self.shape})"
