"""The shared grid core of the DCP (chapter 4) and DCG (chapter 5).

Cells are ``(x, y)`` = ``(row, column)`` with the base at ``(0, 0)`` in the
top-left corner, as in Fig. 4.1. "Up" decreases the row, "left" decreases the
column.

Everything here is a pure function of arrays and works under ``jit``/``vmap``;
the validating constructors (:func:`risk_map`, :func:`validate_risk_map`) run
outside jit.
"""

from __future__ import annotations

import math
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core.validate import check_int

#: The 9 actions in the thesis' order (section 4.3).
ACTIONS: tuple[str, ...] = (
    "stay",
    "up",
    "down",
    "left",
    "right",
    "up_left",
    "up_right",
    "down_left",
    "down_right",
)
NUM_ACTIONS = len(ACTIONS)
STAY = 0

#: Row/column displacement of each action, shape ``[9, 2]``.
DELTAS_NP = np.array(
    [[0, 0], [-1, 0], [1, 0], [0, -1], [0, 1], [-1, -1], [-1, 1], [1, -1], [1, 1]],
    dtype=np.int32,
)

#: Readings of "the action that follows the shortest path" (Algorithm 8).
SHORTEST_MOVE_RULES = ("diagonal", "order")

#: Risk rings of Table 4.2, from outer (rho0) to inner (rho3).
RISK_PRESETS: dict[str, tuple[float, float, float, float]] = {
    "low": (0.01, 0.02, 0.04, 0.08),
    "medium": (0.01, 0.03, 0.09, 0.27),
    "high": (0.01, 0.04, 0.16, 0.64),
}


def move(pos: Any, action: Any, grid_size: int) -> jax.Array:
    """Apply ``action`` to ``pos`` (``[..., 2]`` int), clipped per axis (section 4.3).

    "If a_t makes the agent go out of a grid boundary, the agent stays along
    the axis perpendicular to that boundary": each coordinate is clipped on
    its own, so ``up_left`` from the top edge still moves left.
    """
    return jnp.clip(pos + jnp.asarray(DELTAS_NP)[action], 0, grid_size - 1)


def clip_action(action: Any) -> tuple[jax.Array, jax.Array]:
    """``(action, invalid)``: an action outside ``0 .. 8`` is clipped into that range (below 0 -> ``stay``,
    above 8 -> ``down_right``) and flagged, so that the functional step has one defined behaviour under jit.

    The environments' ``step_env`` apply it and report the flag as ``info["invalid_action"]``; the
    gymnasium adapters refuse such actions before they reach the step.
    """
    return jnp.clip(action, 0, NUM_ACTIONS - 1), (action < 0) | (action >= NUM_ACTIONS)


def neighbours(pos: Any, grid_size: int) -> jax.Array:
    """All 9 successors of ``pos``, shape ``[..., 9, 2]`` (index = action)."""
    return jnp.clip(pos[..., None, :] + jnp.asarray(DELTAS_NP), 0, grid_size - 1)


def chebyshev(a: Any, b: Any) -> jax.Array:
    """Chebyshev distance ``max(|dx|, |dy|)``: the number of moves on the 8-connected grid."""
    return jnp.max(jnp.abs(a - b), axis=-1)


def manhattan(a: Any, b: Any) -> jax.Array:
    """Manhattan distance ``|dx| + |dy|`` (the text of section 4.4.2 names it for CF)."""
    return jnp.sum(jnp.abs(a - b), axis=-1)


def shortest_move(pos: Any, target: Any, grid_size: int, rule: str = "diagonal") -> jax.Array:
    """The action that follows a shortest (fewest-moves) path from ``pos`` to ``target``.

    Algorithm 8: "Select the a that minimizes ``max(|x_z - x_i*|, |y_z - y_i*|)``".
    Several actions usually do; ``rule`` picks one:

    * ``"diagonal"`` -- step ``sign(dx), sign(dy)``: diagonal while both axes
      differ, which keeps the remaining path on the straight line;
    * ``"order"`` -- the first action in the thesis' action order whose
      successor has the smallest Chebyshev distance.

    Returns ``stay`` (0) when ``pos == target``.
    """
    if rule == "diagonal":
        step = jnp.sign(target - pos)
        # Index of (step_row, step_col) in DELTAS_NP via a 3x3 lookup table.
        return jnp.asarray(_STEP_TO_ACTION)[step[..., 0] + 1, step[..., 1] + 1]
    if rule == "order":
        succ = neighbours(pos, grid_size)
        d = chebyshev(succ, target[..., None, :])
        return jnp.argmin(d, axis=-1).astype(jnp.int32)
    raise ValueError(f"shortest_move rule must be one of {SHORTEST_MOVE_RULES}, got {rule!r}")


def _step_table() -> np.ndarray:
    table = np.zeros((3, 3), dtype=np.int32)
    for a, (dr, dc) in enumerate(DELTAS_NP):
        table[dr + 1, dc + 1] = a
    return table


_STEP_TO_ACTION = _step_table()


def cell_coords(grid_size: int) -> jax.Array:
    """``[N*N, 2]`` (row, col) of every cell in row-major order."""
    r, c = np.divmod(np.arange(grid_size * grid_size), grid_size)
    return jnp.asarray(np.stack([r, c], axis=-1).astype(np.int32))


def flat_index(pos: Any, grid_size: int) -> jax.Array:
    """Row-major flat index of ``pos`` (``[..., 2]`` = (row, col))."""
    pos = jnp.asarray(pos)
    return (pos[..., 0] * grid_size + pos[..., 1]).astype(jnp.int32)


def unflat_index(index: Any, grid_size: int) -> jax.Array:
    """The ``(row, col)`` of a row-major flat index, shape ``[..., 2]``."""
    index = jnp.asarray(index)
    return jnp.stack([index // grid_size, index % grid_size], axis=-1).astype(jnp.int32)


def ring_index(grid_size: int) -> np.ndarray:
    """Concentric ring of each cell, 0 (outermost) .. 3 (innermost), shape ``[N, N]``.

    For N = 8 this is exactly Fig. 4.1b: ring = distance to the nearest
    border. For other sizes (a rule of jaxdc, the thesis only shows N = 8) the
    border distance ``d`` in ``0..D`` with ``D = (N - 1) // 2`` is mapped to
    ``round(3 d / D)``, so the outermost ring is always rho0 and the centre is
    always rho3, with bands of (nearly) equal width in between. ``N = 2`` has
    only the outer ring.
    """
    idx = np.arange(grid_size)
    d = np.minimum(idx, grid_size - 1 - idx)
    d = np.minimum(d[:, None], d[None, :])
    depth = (grid_size - 1) // 2
    if depth == 0:
        return np.zeros((grid_size, grid_size), dtype=np.int32)
    return np.floor(3.0 * d / depth + 0.5).astype(np.int32)


def risk_map(preset: str, grid_size: int = 8) -> np.ndarray:
    """A preset risk map of Table 4.2 (``low``, ``medium``, ``high``); base risk 0."""
    if preset not in RISK_PRESETS:
        raise ValueError(f"risk preset must be one of {sorted(RISK_PRESETS)}, got {preset!r}")
    check_grid_size(grid_size)
    rho = np.asarray(RISK_PRESETS[preset], dtype=np.float32)[ring_index(grid_size)]
    rho[0, 0] = 0.0
    return rho


def check_grid_size(grid_size: Any, max_cells: int | None = None) -> int:
    """Validate a grid size (an int >= 2; with ``max_cells``, also ``N * N <= max_cells``)."""
    n = check_int("grid_size", grid_size, 2)
    if max_cells is not None and n**2 > max_cells:
        raise ValueError(f"grid_size must be <= {math.isqrt(max_cells)} (N*N cells <= {max_cells}), got {grid_size}")
    return n


def validate_risk_map(risk: Any, grid_size: int | None = None) -> np.ndarray:
    """Check a user risk map: a square ``N x N`` array of finite values in ``[0, 1]`` with base risk 0."""
    bad = _first_non_number(risk)
    if bad is not None:
        cell, v = bad
        kind = "a boolean" if isinstance(v, (bool, np.bool_)) else f"not a number ({type(v).__name__})"
        shown = str(v).lower() if isinstance(v, (bool, np.bool_)) else repr(v)
        raise TypeError(f"risk map cell ({', '.join(map(str, cell))}) is {kind}: {shown}; "
                        "risks must be numbers in [0, 1]")
    try:
        arr = np.asarray(risk, dtype=np.float32)
    except (TypeError, ValueError) as e:
        raise TypeError(f"risk map must be a numeric N x N array: {e}") from None
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise ValueError(f"risk map must be a square N x N array, got shape {arr.shape}")
    check_grid_size(arr.shape[0])
    if grid_size is not None and arr.shape[0] != grid_size:
        raise ValueError(f"risk map is {arr.shape[0]}x{arr.shape[0]} but grid_size is {grid_size}")
    if not np.all(np.isfinite(arr)):
        r, c = (int(i) for i in np.argwhere(~np.isfinite(arr))[0])
        raise ValueError(f"risk map values must be finite numbers in [0, 1], got {arr[r, c]} at cell ({r}, {c})")
    if arr.min() < 0 or arr.max() > 1:
        r, c = (int(i) for i in np.argwhere((arr < 0) | (arr > 1))[0])
        raise ValueError(f"risk map values must lie in [0, 1], got {arr[r, c]} at cell ({r}, {c}) (min {arr.min()}, "
                         f"max {arr.max()})")
    if arr[0, 0] != 0:
        raise ValueError(f"the base cell (0, 0) must have risk 0, got {arr[0, 0]}")
    return arr


def _first_non_number(value, where=()):
    """``(cell, value)`` of the first cell of a risk map given as nested lists or an array that is a boolean
    or no real number (``np.asarray`` would read ``True`` as 1), or ``None``."""
    if not isinstance(value, (list, tuple, np.ndarray)) and hasattr(value, "shape") and hasattr(value, "dtype"):
        value = np.asarray(value)  # a JAX array or another array type
    if isinstance(value, np.ndarray):
        if value.dtype == np.bool_:
            return ((0,) * value.ndim, bool(value.flat[0])) if value.size else ((), None)
        if value.dtype != object:
            return None
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            bad = _first_non_number(v, where + (i,))
            if bad is not None:
                return bad
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        return where, value
    return None


def as_risk_map(risk: Any, grid_size: int = 8) -> np.ndarray:
    """A preset name or a user array -> a validated ``[N, N]`` float32 risk map."""
    if isinstance(risk, str):
        return risk_map(risk, grid_size)
    return validate_risk_map(risk, grid_size)
