"""Navigation algorithms (Algorithm 9) and the ten ENN heuristics (section 4.4.3).

Algorithm 9 combines a planner ``N1`` towards items with a planner ``N0``
towards the base: go for the item ``i*`` of ``N1`` only if the energy covers
the path to it plus ``N0``'s path from it back home (``e >= l1 + l0'``).

=============  ====================  ================
navigator      items (``N1``)        base (``N0``)
=============  ====================  ================
safe_reward    LPG (Algorithm 7)     shortest path
safe_recharge  CF (Algorithm 8)      safest path
safe_both      LPG                   safest path
safe_neither   CF                    shortest path
=============  ====================  ================

Every function here is a pure function of the DCP state, the env params and
the safest-path table of those params.
"""

from __future__ import annotations

import functools
from typing import cast

import jax
import jax.numpy as jnp

from jaxdc.core import grid
from jaxdc.core.hop_paths import safest_within
from jaxdc.core.paths import PathTable
from jaxdc.core.tour_criteria import APPEND_CRITERIA
from jaxdc.core.validate import is_int
from jaxdc.dcp import planners
from jaxdc.dcp.planners import Plan, PlannerConfig

#: (items planner, base planner) of each navigation algorithm of section 4.4.2.
NAVIGATORS: dict[str, tuple[str, str]] = {
    "safe_reward": ("lpg", "fast_home"),
    "safe_recharge": ("cf", "safe_home"),
    "safe_both": ("lpg", "safe_home"),
    "safe_neither": ("cf", "fast_home"),
}

#: The ten ENN heuristics, in the order of section 4.4.3 (rows of :func:`enn_heuristics`).
HEURISTICS = (
    "safe_reward",
    "safe_recharge",
    "safe_both",
    "safe_neither",
    "loss_per_gain",
    "closest_first",
    "safe_trip_home",
    "fast_trip_home",
    "distance_to_home",
    "risk",
)

#: The ten rows and an eleventh, budget-aware one (beyond the thesis; :func:`safe_budget_action`): the rows of
#: ``enn_heuristics(..., rows=11)``.
BUDGET_HEURISTICS = HEURISTICS + ("safe_budget",)

#: The row counts :func:`enn_heuristics` computes: the thesis' ten, or the ten and Safe-Budget.
HEURISTIC_ROWS = (len(HEURISTICS), len(BUDGET_HEURISTICS))

#: Single-planner policies of Table 4.1 (no energy constraint) plus CF.
PLANNER_POLICIES = tuple(APPEND_CRITERIA) + ("cf",)

#: Every heuristic policy name accepted by :func:`policy_action` (Safe-Budget is beyond the thesis).
POLICIES = tuple(NAVIGATORS) + PLANNER_POLICIES + ("safe_budget",)


def _item_plan(name: str, state, table: PathTable, cfg: PlannerConfig) -> Plan:
    planner = planners.cf if name == "cf" else planners.tour_planner(name)
    return planner(state.pos, state.items, table, cfg, state.rank)


def _home(name: str, pos, grid_size: int, table: PathTable, cfg: PlannerConfig) -> Plan:
    return getattr(planners, name)(pos, grid_size, table, cfg)


def navigate(items_plan: Plan, home_now: Plan, home_after, energy):
    """Algorithm 9's decision: the item's action if ``energy >= l1 + l0'``, else the way home."""
    go_home = energy < (items_plan.length + home_after).astype(energy.dtype)
    return jnp.where(go_home, home_now.action, items_plan.action).astype(jnp.int32)


def navigator_action(name: str, state, table: PathTable, cfg: PlannerConfig = PlannerConfig()):
    """The action of navigation algorithm ``name`` (Algorithm 9) in ``state``."""
    if name not in NAVIGATORS:
        raise ValueError(f"navigator must be one of {tuple(NAVIGATORS)}, got {name!r}")
    n1, n0 = NAVIGATORS[name]
    n = state.items.shape[0]
    item = _item_plan(n1, state, table, cfg)
    home_now = _home(n0, state.pos, n, table, cfg)
    home_after = _home(n0, grid.unflat_index(item.target, n), n, table, cfg).length
    return navigate(item, home_now, home_after, state.energy)


#: Safe-Budget goes now unless recharging first is safer by more than this relative margin (float ties).
BUDGET_TIE_RTOL = 1e-4


def _row(x, i: int):
    return x[i]


def safe_budget_action(state, table: PathTable, max_energy, cfg: PlannerConfig = PlannerConfig(),
                       item: Plan | None = None):
    """Safe-Budget (beyond the thesis): Algorithm 9 with LPG's item and routes that fit the energy.

    The safest-path heuristics of section 4.4.3 ignore the budget: when the safest path to an item is too long,
    the navigators turn home, and if it does not fit a full battery they never go. Safe-Budget heads for LPG's item
    along the safest route of at most ``e - d`` moves (:func:`jaxdc.core.hop_paths.safest_within`), ``e`` the energy
    and ``d`` the fewest moves from the item back to the base (Chebyshev), so that the way home still fits; when
    the item is the last item cell no way home is needed, and the route may use all ``e`` moves (the reward is
    collected on entering the cell). It goes now unless recharging first is safer (by more than
    :data:`BUDGET_TIE_RTOL`, so that float ties go to going now): the
    safest way home within ``e`` moves, then the safest route from the base within ``max_energy - d`` moves (a
    full battery may open a safer detour). Otherwise, or when no route fits, it heads home along the safest route
    the energy allows (in the base: stays, which recharges), and where none fits, along the shortest path.
    ``item`` is LPG's plan in ``state`` when the caller has it (:func:`enn_heuristics`), else it is computed.
    """
    n = state.items.shape[0]
    cells = n * n
    z = grid.flat_index(state.pos, n)
    item = _item_plan("lpg", state, table, cfg) if item is None else item
    item_cells = jnp.sum(state.items > 0)
    back = jnp.where(item_cells <= 1, 0, grid.chebyshev(grid.unflat_index(item.target, n), jnp.zeros(2, jnp.int32)))

    def moves(e):  # an unlimited budget: N^2 moves (no route needs more)
        return jnp.floor(jnp.minimum(e, float(cells))).astype(jnp.int32)

    energy, full = moves(state.energy), moves(jnp.asarray(max_energy, jnp.float32))
    # Three routes in one batch: to the item now, home now, and to the item from the base on a full battery.
    routes = jax.vmap(safest_within, in_axes=(None, 0, 0, 0))(
        table, jnp.stack([z, z, jnp.int32(0)]), jnp.stack([item.target, jnp.int32(0), item.target]),
        jnp.stack([energy - back, energy, full - back]))
    now, home, later = (jax.tree_util.tree_map(functools.partial(_row, i=i), routes) for i in range(3))
    # Ties go to going now, within BUDGET_TIE_RTOL: on zero-risk cells the two are equal, and float noise deciding
    # them could send the agent back and forth between the base and its first cell.
    go_now = (item_cells > 0) & now.feasible & (now.success >= (1.0 - BUDGET_TIE_RTOL) * home.success * later.success)
    fast = _home("fast_home", state.pos, n, table, cfg).action
    return jnp.where(go_now, now.action, jnp.where(home.feasible, home.action, fast)).astype(jnp.int32)


def policy_action(name: str, state, table: PathTable, cfg: PlannerConfig = PlannerConfig(), max_energy=None):
    """Any heuristic policy by name: a navigator, a bare planner (Table 4.1: ng, osa, tl, gml, lpg, cf) or
    Safe-Budget (:func:`safe_budget_action`, which also reads the episode's ``max_energy``)."""
    if name in NAVIGATORS:
        return navigator_action(name, state, table, cfg)
    if name == "safe_budget":
        if max_energy is None:
            raise ValueError("policy 'safe_budget' needs the episode's max_energy")
        return safe_budget_action(state, table, max_energy, cfg)
    if name in PLANNER_POLICIES:
        return _item_plan(name, state, table, cfg).action.astype(jnp.int32)
    raise ValueError(f"policy must be one of {POLICIES}, got {name!r}")


def batched_heuristics(params, table: PathTable, cfg: PlannerConfig = PlannerConfig(), rows: int = 10):
    """``env_states [B] -> [B, rows, 9]``: :func:`enn_heuristics` over a batch sharing ``params`` and ``table``.

    This is what a trainer of ENN or EQN is given (``jaxdc.agents`` knows no heuristics itself).
    """
    check_rows(rows)
    return lambda states: jax.vmap(enn_heuristics, in_axes=(0, None, None, None, None))(states, params, table, cfg,
                                                                                          rows)


def check_rows(rows: object, name: str = "rows") -> int:
    """``rows`` if it is one of :data:`HEURISTIC_ROWS` (outside jit), else a ``ValueError`` naming it (``name``)."""
    if not is_int(rows, numpy=False) or rows not in HEURISTIC_ROWS:
        raise ValueError(f"{name} (the number of ENN heuristics) must be one of {HEURISTIC_ROWS}, got {rows!r}")
    return int(cast(int, rows))


def enn_heuristics(state, params, table: PathTable, cfg: PlannerConfig = PlannerConfig(), rows: int = 10):
    """The action vectors of ENN (section 4.4.3), shape ``[rows, 9]``, rows in :data:`BUDGET_HEURISTICS` order.

    Rows 0-7 are one-hot: the four navigators, LPG, CF, Safe-Trip-Home and
    Fast-Trip-Home. Row 8 (Distance-To-Home) is the Chebyshev distance to
    the base after each action; row 9 (Risk) is the risk of the cell each
    action leads to. Each planner is computed once and shared. With
    ``rows=11`` (beyond the thesis), row 10 is Safe-Budget one-hot
    (:func:`safe_budget_action`: the route that fits the energy).
    """
    check_rows(rows)
    n = state.items.shape[0]
    items = {name: _item_plan(name, state, table, cfg) for name in ("lpg", "cf")}
    homes = {h: _home(h, state.pos, n, table, cfg) for h in ("safe_home", "fast_home")}
    navs = [
        navigate(items[n1], homes[n0], _home(n0, grid.unflat_index(items[n1].target, n), n, table, cfg).length,
                 state.energy)
        for n1, n0 in NAVIGATORS.values()
    ]
    singles = [items["lpg"].action, items["cf"].action, homes["safe_home"].action, homes["fast_home"].action]
    actions = jnp.stack(navs + singles).astype(jnp.int32)
    one_hot = jax.nn.one_hot(actions, grid.NUM_ACTIONS, dtype=jnp.float32)
    succ = grid.neighbours(state.pos, n)  # [9, 2]
    dist_home = grid.chebyshev(succ, jnp.zeros(2, jnp.int32)).astype(jnp.float32)
    risk = params.risk[succ[:, 0], succ[:, 1]]
    ten = jnp.concatenate([one_hot, dist_home[None], risk[None]], axis=0)
    if rows == len(HEURISTICS):
        return ten
    budget = jax.nn.one_hot(safe_budget_action(state, table, params.max_energy, cfg, items["lpg"]),
                            grid.NUM_ACTIONS, dtype=jnp.float32)
    return jnp.concatenate([ten, budget[None]], axis=0)
