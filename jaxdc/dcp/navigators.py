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

import jax
import jax.numpy as jnp

from jaxdc.core import grid
from jaxdc.core.paths import PathTable
from jaxdc.core.tour_criteria import APPEND_CRITERIA
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

#: Single-planner policies of Table 4.1 (no energy constraint) plus CF.
PLANNER_POLICIES = tuple(APPEND_CRITERIA) + ("cf",)

#: Every heuristic policy name accepted by :func:`policy_action`.
POLICIES = tuple(NAVIGATORS) + PLANNER_POLICIES


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


def policy_action(name: str, state, table: PathTable, cfg: PlannerConfig = PlannerConfig()):
    """Any heuristic policy by name: a navigator, or a bare planner (Table 4.1: ng, osa, tl, gml, lpg, cf)."""
    if name in NAVIGATORS:
        return navigator_action(name, state, table, cfg)
    if name in PLANNER_POLICIES:
        return _item_plan(name, state, table, cfg).action.astype(jnp.int32)
    raise ValueError(f"policy must be one of {POLICIES}, got {name!r}")


def batched_heuristics(params, table: PathTable, cfg: PlannerConfig = PlannerConfig()):
    """``env_states [B] -> [B, 10, 9]``: :func:`enn_heuristics` over a batch sharing ``params`` and ``table``.

    This is what a trainer of ENN or EQN is given (``jaxdc.agents`` knows no heuristics itself).
    """
    return lambda states: jax.vmap(enn_heuristics, in_axes=(0, None, None, None))(states, params, table, cfg)


def enn_heuristics(state, params, table: PathTable, cfg: PlannerConfig = PlannerConfig()):
    """The ten action vectors of ENN (section 4.4.3), shape ``[10, 9]``, rows in :data:`HEURISTICS` order.

    Rows 0-7 are one-hot: the four navigators, LPG, CF, Safe-Trip-Home and
    Fast-Trip-Home. Row 8 (Distance-To-Home) is the Chebyshev distance to
    the base after each action; row 9 (Risk) is the risk of the cell each
    action leads to. Each planner is computed once and shared.
    """
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
    return jnp.concatenate([one_hot, dist_home[None], risk[None]], axis=0)
