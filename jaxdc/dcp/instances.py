"""Per-episode DCP instances: a set of risk maps and a budget range that each episode draws from.

Beyond the thesis (its conclusion's open problem: one network for every
budget and map). :func:`instance_params` turns a set of maps ``[M, N, N]``
(from :func:`jaxdc.core.generators.make_maps`, or any validated maps) and a
range of maximum energies into :class:`~jaxdc.dcp.env.EnvParams` whose
``maps``, ``tables``, ``energy_range`` and ``init_fraction`` are set. Each
reset then draws its map uniformly and its maximum energy uniformly among the
integers of the range (or, with ``energy_tilt``, by a power law that weights
one end: :func:`jaxdc.core.energy.draw_max_energy`); the initial energy is ``init_fraction`` of it (the
thesis' settings all start at half the maximum: 8/16, 16/32).

The safest-path table of every map (section 4.4.1) is computed once here and
kept in the params: ``M`` maps of ``N x N`` cells hold ``12 M N^4`` bytes
(48 KiB a map at ``N = 8``; 1,024 maps: 48 MiB). The navigators and the ENN
heuristics of an episode read its own map's table (:func:`state_table`).

One map and one budget (``energy_range = (E, E)``) is the thesis' setting
played through this path: :func:`fixed_instance` builds it, so a general
network is evaluated on a thesis map exactly like any other.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core import grid
from jaxdc.core.energy import check_energy_tilt
from jaxdc.core.memory import check_fits
from jaxdc.core.paths import PathTable, safest_paths
from jaxdc.core.validate import check_float
from jaxdc.dcp import navigators
from jaxdc.dcp.env import DCP, EnvParams, EnvState
from jaxdc.dcp.param_values import check_energy, check_energy_range, check_maps
from jaxdc.dcp.planners import PlannerConfig

#: Maps whose tables are computed in one batched call (bounds the memory of the Dijkstra batch).
TABLE_CHUNK = 64


def table_bytes(maps: int, grid_size: int) -> int:
    """Bytes of the safest-path tables of ``maps`` maps: three ``[N^2, N^2]`` 4-byte arrays each."""
    return 12 * maps * grid_size**4


#: The tables of a batch of maps, compiled once per batch shape.
_batched_tables = jax.jit(jax.vmap(safest_paths))


def compute_tables(maps: np.ndarray) -> PathTable:
    """The safest-path table of every map, stacked: leaves ``[M, N^2, N^2]`` (computed ``TABLE_CHUNK`` at a time)."""
    parts = [jax.device_get(_batched_tables(jnp.asarray(maps[i:i + TABLE_CHUNK])))
             for i in range(0, len(maps), TABLE_CHUNK)]
    return jax.tree_util.tree_map(lambda *xs: jnp.asarray(np.concatenate(xs)), *parts)


def instance_params(env: DCP, maps: Any, energy_range: Any, init_fraction: float = 0.5,
                    max_steps: int = 1000, energy_tilt: float = 0.0) -> EnvParams:
    """Params whose episodes draw their risk map from ``maps`` and their maximum energy from ``energy_range``.

    Args:
      env: the DCP the params are for (its grid size).
      maps: ``[M, N, N]`` risk maps (base 0, risks in ``[0, 1)``).
      energy_range: ``(low, high)``, whole numbers ``2 <= low <= high``: the maximum energy of an episode is
        uniform over the integers of this range.
      init_fraction: the initial energy is ``round(init_fraction * maximum)``, at least 1 (``(0, 1]``).
      max_steps: the step cap.
      energy_tilt: 0 (default): the maximum energy is uniform over the integers of ``energy_range``. Otherwise a
        power-law tilt of that draw (beyond the thesis; :func:`jaxdc.core.energy.draw_max_energy`: each integer
        ``E`` has the mass of ``x ** -energy_tilt`` over ``[E, E + 1)``, so a positive tilt weights the small
        budgets), finite in ``[-MAX_ENERGY_TILT, MAX_ENERGY_TILT]``. 0 gives the same params (and games) as before.
    """
    arr = check_maps(maps, env.grid_size)
    low, high = check_energy_range(energy_range)
    tilt = check_energy_tilt(energy_tilt)
    frac = check_float("init_fraction", init_fraction, 0.0, 1.0, low_open=True)
    check_fits(table_bytes(arr.shape[0], env.grid_size),
               f"the safest-path tables of {arr.shape[0]} maps of {env.grid_size}x{env.grid_size}",
               "the number of maps or the grid size")
    base = env.make_params(arr[0], (max(1.0, round(frac * high)), high), max_steps)
    return dataclasses.replace(base, maps=jnp.asarray(arr), tables=compute_tables(arr),
                        energy_range=jnp.asarray([low, high], jnp.float32), init_fraction=jnp.float32(frac),
                        energy_tilt=None if tilt == 0.0 else jnp.float32(tilt))


def fixed_instance(env: DCP, risk: Any, energy: Any, max_steps: int = 1000) -> EnvParams:
    """One map and one budget ``(initial, maximum)`` through the per-episode path (the thesis' settings for a
    network that reads the instance)."""
    init_e, max_e = check_energy(energy)
    if max_e == float("inf"):
        raise ValueError("energy: per-episode instances need a finite maximum energy, got inf")
    arr = grid.as_risk_map(risk, env.grid_size)[None]
    return instance_params(env, arr, (max_e, max_e), init_e / max_e, max_steps)


def state_table(params: EnvParams, state: EnvState, shared: PathTable | None = None) -> PathTable:
    """The safest-path table of ``state``'s episode: its map's row of ``params.tables``, or ``shared`` (the one
    table of params without per-episode maps)."""
    if params.maps is None:
        if shared is None:
            raise ValueError("params without per-episode maps need the shared table")
        return shared
    return jax.tree_util.tree_map(lambda t: t[state.map_id], params.tables)


def state_params(params: EnvParams, state: EnvState) -> EnvParams:
    """``params`` with ``risk`` and the energies of ``state``'s episode (what the planners and heuristics read)."""
    if params.maps is None or state.max_energy is None:
        return params
    return dataclasses.replace(params, risk=params.maps[state.map_id], max_energy=state.max_energy)


def batched_heuristics(params: EnvParams, cfg: PlannerConfig = PlannerConfig(), rows: int = 10) -> Callable:
    """``env_states [B] -> [B, rows, 9]``: the ENN heuristics of each episode on its own map's table (``rows``: 10,
    the thesis', or 11 with Safe-Budget, :func:`jaxdc.dcp.navigators.enn_heuristics`)."""
    navigators.check_rows(rows)

    def one(state):
        return navigators.enn_heuristics(state, state_params(params, state), state_table(params, state), cfg, rows)

    return jax.vmap(one)


def heuristic_policy(name: str, params: EnvParams, cfg: PlannerConfig = PlannerConfig()) -> Callable:
    """``policy(key, obs, state)`` of a navigator or planner, on each episode's own table."""
    if name not in navigators.POLICIES:
        raise ValueError(f"policy must be one of {navigators.POLICIES}, got {name!r}")

    def policy(key, obs, state):
        return navigators.policy_action(name, state, state_table(params, state), cfg,
                                        state_params(params, state).max_energy)

    return policy


__all__ = ["TABLE_CHUNK", "batched_heuristics", "check_energy_range", "check_maps", "compute_tables",
           "fixed_instance", "heuristic_policy", "instance_params", "state_params", "state_table", "table_bytes"]
