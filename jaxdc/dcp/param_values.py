"""The values of the DCP's parameters, checked on concrete arrays (issue 31; section 4.3's settings).

:meth:`jaxdc.dcp.env.DCP.make_params` and :func:`jaxdc.dcp.instances.instance_params` validate what they
build with the checks here (the energies, the per-episode maps and budget range); :func:`check_param_values`
applies the same checks to a whole :class:`~jaxdc.dcp.types.EnvParams`, for parameters that bypassed those
builders (edited with ``.replace``): :meth:`jaxdc.dcp.env.DCP.check_param_values` runs it once at the non-jitted
entry points.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from jaxdc.core import grid
from jaxdc.core.energy import check_budget, check_energy_tilt
from jaxdc.core.energy import check_energy_range as check_range
from jaxdc.core.env import check_each, is_traced
from jaxdc.core.validate import INT32_MAX, check_float, check_int, value_text
from jaxdc.dcp.types import EnvParams

#: The smallest maximum energy of a per-episode budget range.
MIN_RANGE_ENERGY = 2.0


def check_energy(energy: Any) -> tuple[float, float]:
    """Validate ``(initial, maximum)`` energy: ``0 < initial <= maximum``, each finite (at most
    :data:`~jaxdc.core.energy.MAX_FINITE_ENERGY`) or ``inf``."""
    try:
        init_e, max_e = energy
    except (TypeError, ValueError):
        raise TypeError(f"energy must be a pair (initial, maximum) of numbers, got {energy!r}") from None
    init_e = check_budget("initial energy", init_e)
    max_e = check_budget("maximum energy", max_e)
    if init_e > max_e:
        raise ValueError(f"initial energy ({value_text(init_e)}) must not exceed the maximum energy "
                         f"({value_text(max_e)})")
    return init_e, max_e


def check_maps(maps: Any, grid_size: int) -> np.ndarray:
    """``maps`` as a validated ``[M, N, N]`` float32 array: each map as :func:`jaxdc.core.grid.validate_risk_map`
    accepts, and no risk of 1 (a certain loss: the safest paths are then undefined)."""
    arr = np.asarray(maps, dtype=np.float32) if not isinstance(maps, np.ndarray) else maps.astype(np.float32)
    if arr.ndim != 3 or arr.shape[0] < 1:
        raise ValueError(f"maps must be an array [M, N, N] with M >= 1, got shape {arr.shape}")
    for i in range(arr.shape[0]):
        try:
            grid.validate_risk_map(arr[i], grid_size)
        except (TypeError, ValueError) as e:
            raise type(e)(f"maps[{i}]: {e}") from None
    if np.any(arr >= 1.0):
        i = int(np.argwhere(arr >= 1.0)[0][0])
        raise ValueError(f"maps[{i}] has a risk of 1; per-episode maps need risks in [0, 1)")
    return arr


def check_energy_range(energy_range: Any) -> tuple[float, float]:
    """``(low, high)``: integer maximum energies with ``MIN_RANGE_ENERGY <= low <= high`` (finite;
    :func:`jaxdc.core.energy.check_energy_range`)."""
    return check_range(energy_range, MIN_RANGE_ENERGY)


def check_param_values(params: EnvParams, name: str = "params") -> EnvParams:
    """``params`` if their VALUES are those :meth:`jaxdc.dcp.env.DCP.make_params` (and
    :func:`jaxdc.dcp.instances.instance_params` for per-episode instances) accept: the risk map finite in
    ``[0, 1]`` with base risk 0, the energies ``0 < initial <= maximum`` (each finite or ``inf``), ``max_steps`` an
    int in ``[1, 2**31 - 1]``, and, with per-episode instances, each map as :func:`check_maps` accepts, the energy
    range, tilt and initial fraction in range. Else a ``TypeError``/``ValueError`` naming ``name.<field>``, the
    value and the allowed range.

    The shapes are :meth:`~jaxdc.core.env.Environment.check_params`' business; traced parameters (inside
    ``jit``/``vmap``) are returned unchecked (their values are not known there)."""
    if is_traced(params):
        return params

    def named(field: str, check: Any) -> None:
        try:
            check()
        except (TypeError, ValueError) as e:
            raise type(e)(f"{name}.{field}: {e}") from None

    named("risk", lambda: grid.validate_risk_map(np.asarray(params.risk)))
    inits, maxes = np.asarray(params.init_energy).reshape(-1), np.asarray(params.max_energy).reshape(-1)
    if inits.size != maxes.size or inits.size == 0:
        raise ValueError(f"{name}.init_energy has {inits.size} values but {name}.max_energy {maxes.size}")
    for init_e, max_e in zip(inits.tolist(), maxes.tolist()):
        named("init_energy/max_energy", lambda i=init_e, m=max_e: check_energy((i, m)))
    check_each(params, "max_steps", lambda v: check_int("max_steps", v, 1, INT32_MAX), name)
    if params.maps is not None:
        named("maps", lambda: check_maps(np.asarray(params.maps), np.asarray(params.risk).shape[-1]))
    if params.energy_range is not None:
        named("energy_range", lambda: check_energy_range(np.asarray(params.energy_range).tolist()))
    if params.energy_tilt is not None:
        check_each(params, "energy_tilt", check_energy_tilt, name)
    if params.init_fraction is not None:
        check_each(params, "init_fraction", lambda v: check_float("init_fraction", v, 0.0, 1.0, low_open=True), name)
    return params


__all__ = ["MIN_RANGE_ENERGY", "check_energy", "check_energy_range", "check_maps", "check_param_values"]
