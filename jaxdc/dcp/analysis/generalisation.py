"""Measuring generalisation: a network over a grid of maps and budgets, against the navigators and the optimum.

Beyond the thesis (its conclusion's open problem on energy, and the same
question for risk maps). A :class:`Setting` is one map and one budget; the
grid of :func:`settings` crosses maps from three sources with budgets:

* ``train`` -- maps of the network's own training set (its ``map_seeds``);
* ``held-out`` -- generated maps of seeds no training run may use
  (:data:`jaxdc.training.instances.HELD_OUT`);
* ``thesis`` -- the three maps of Table 4.2.

A budget is *inside* when its maximum lies in the network's training range
(interpolation), else *outside* (extrapolation). :func:`evaluate_setting`
plays, on the same episode keys: the network; the four navigators of
Algorithm 9 (the best of them is the yardstick); with ``optimum``, the
network on one item against the exact single-item optimum
(:mod:`jaxdc.dcp.exact.optimal`, value iteration on that map and budget); and the
specialist, a shipped network trained in exactly that setting, where one
exists; with ``bound``, the unlimited-energy bound of every policy on the same
episodes (:mod:`jaxdc.dcp.exact.unlimited`, at most 20 items), whose ratio to the
best navigator is the most any policy could gain over it there (the *ceiling*).
:func:`summarise` groups the ratios by source and inside/outside.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable

import jax
import numpy as np

from jaxdc.core import generators, grid
from jaxdc.dcp import instances
from jaxdc.dcp.env import DCP
from jaxdc.dcp.evaluate import evaluate_heuristic, evaluate_learned
from jaxdc.dcp.exact.optimal import expected_optimum, solve_single_item
from jaxdc.dcp.exact.unlimited import check_bound_fits, evaluate_bound
from jaxdc.dcp.navigators import NAVIGATORS

#: The map sources of a generalisation grid, in report order.
SOURCES = ("train", "held-out", "thesis")
#: Budgets ``(initial, maximum)`` of the default grid: the thesis' two (8/16, 16/32) and others around them.
BUDGETS = ((4.0, 8.0), (6.0, 12.0), (8.0, 16.0), (12.0, 24.0), (16.0, 32.0), (24.0, 48.0), (32.0, 64.0))


@dataclasses.dataclass(frozen=True)
class Setting:
    """One cell of the grid: a map (its source and name) and a budget."""

    source: str  # one of SOURCES
    map_name: str  # "train 12" (its seed), "held-out 1073741827", "high"
    risk: np.ndarray = dataclasses.field(compare=False, repr=False)
    energy: tuple[float, float] = (8.0, 16.0)
    inside: bool = True  # the maximum energy lies in the training range


def training_range(metadata: dict) -> tuple[float, float]:
    """The maximum energies a network was trained on: its ``energy_range``, else its one budget."""
    if "energy_range" in metadata:
        low, high = metadata["energy_range"]
        return float(low), float(high)
    e = float(metadata.get("energy", (8.0, 16.0))[1])
    return e, e


def settings(metadata: dict, maps_per_source: int = 2, budgets=BUDGETS, grid_size: int = 8,
             generator: str | None = None) -> list[Setting]:
    """The grid for a network of ``metadata``: ``maps_per_source`` training maps (its first seeds) and held-out
    maps (drawn with ``generator``, default the network's own ``risk_maps``), the thesis' three maps; each with
    every budget of ``budgets``."""
    low, high = training_range(metadata)
    gen_name = generator or metadata.get("risk_maps") or "mix"
    gen = generators.generator(gen_name)
    start = int(metadata.get("map_seeds", (0, 1))[0])
    train = generators.SeedSet(start, maps_per_source)
    test = generators.SeedSet(generators.TEST_SEED_START, maps_per_source)
    maps: list[tuple[str, str, np.ndarray]] = []
    if "risk_maps" in metadata:
        maps += [("train", f"train {s}", m)
                 for s, m in zip(train.seeds(), generators.make_maps(generators.generator(metadata["risk_maps"]),
                                                                     train, grid_size))]
    maps += [("held-out", f"held-out {s}", m) for s, m in zip(test.seeds(), generators.make_maps(gen, test, grid_size))]
    maps += [("thesis", name, grid.risk_map(name, grid_size)) for name in ("low", "medium", "high")]
    return [Setting(src, name, risk, (float(e0), float(e1)), low <= float(e1) <= high)
            for src, name, risk in maps for e0, e1 in budgets]


def _mean_se(final) -> tuple[float, float]:
    r = np.asarray(final.ep_reward, np.float64)
    return float(r.mean()), float(r.std() / math.sqrt(len(r)))


def evaluate_setting(learned, setting: Setting, total_reward: int = 30, episodes: int = 2000, seed: int = 0,
                     optimum: bool = True, specialist: Callable[[Setting], Any] | None = None,
                     greedy: bool = False, bound: bool = False) -> dict:
    """One row of the grid: the network, the best of the thesis' four navigators, Safe-Budget (beyond the thesis:
    :func:`jaxdc.dcp.navigators.safe_budget_action`, with its ratio to that best), the single-item optimum, the
    specialist and, with ``bound``, the unlimited-energy bound (``total_reward`` <= 20, else ``ValueError``).

    Every policy plays the same episode keys (``seed``). Returns a JSON-able dict.
    """
    key = jax.random.PRNGKey(seed)
    row: dict[str, Any] = {"source": setting.source, "map": setting.map_name, "energy": list(setting.energy),
                           "inside": setting.inside, "total_reward": total_reward, "episodes": episodes}
    env = DCP(grid_size=setting.risk.shape[0], total_reward=total_reward, observation=learned.observation)
    if bound:
        check_bound_fits(env)
    params = instances.fixed_instance(env, setting.risk, setting.energy)
    row["net"] = dict(zip(("mean", "se"), _mean_se(evaluate_learned(env, params, learned, key, episodes, greedy))))
    navs = {name: _mean_se(evaluate_heuristic(env, params, name, key, episodes)) for name in NAVIGATORS}
    best = max(navs, key=lambda n: navs[n][0])
    row["navigators"] = {n: {"mean": m, "se": se} for n, (m, se) in navs.items()}
    row["best_navigator"] = {"name": best, "mean": navs[best][0], "se": navs[best][1]}
    row["ratio"] = row["net"]["mean"] / navs[best][0] if navs[best][0] > 0 else None
    # Beyond the thesis' four: Safe-Budget, the navigator whose routes fit the energy (the eleventh ENN row).
    m, se = _mean_se(evaluate_heuristic(env, params, "safe_budget", key, episodes))
    row["safe_budget"] = {"mean": m, "se": se, "ratio": m / navs[best][0] if navs[best][0] > 0 else None}
    if bound:
        b = evaluate_bound(env, params, key, episodes)
        row["bound"] = {"mean": b.mean, "se": b.se, "net_share": row["net"]["mean"] / b.mean if b.mean > 0 else None,
                        "navigator_share": navs[best][0] / b.mean if b.mean > 0 else None,
                        "ceiling": b.mean / navs[best][0] if navs[best][0] > 0 else None}
    if optimum:
        row["one_item"] = one_item(learned, setting, episodes, seed, greedy)
    if specialist is not None:
        spec = specialist(setting)
        if spec is not None:
            s_env = DCP(grid_size=setting.risk.shape[0], total_reward=total_reward)
            s_params = s_env.make_params(setting.risk, setting.energy)
            m, se = _mean_se(evaluate_learned(s_env, s_params, spec, key, episodes))
            row["specialist"] = {"name": spec.source, "mean": m, "se": se}
    return row


def one_item(learned, setting: Setting, episodes: int = 2000, seed: int = 0, greedy: bool = False) -> dict:
    """The network with one item against the exact optimum of that map and budget (value iteration)."""
    env = DCP(grid_size=setting.risk.shape[0], total_reward=1, observation=learned.observation)
    params = instances.fixed_instance(env, setting.risk, setting.energy)
    m, se = _mean_se(evaluate_learned(env, params, learned, jax.random.PRNGKey(seed), episodes, greedy))
    sol = solve_single_item(np.asarray(setting.risk), setting.energy[1], setting.energy[0],
                            grid_size=setting.risk.shape[0])
    opt = expected_optimum(sol, env.items_on_base, env.start)
    return {"net": m, "net_se": se, "optimum": opt, "share": m / opt if opt > 0 else None}


def summarise(rows: list[dict]) -> list[dict]:
    """Mean ratio (network / best navigator) and one-item share by map source and inside/outside; with the bound,
    also the mean and smallest ceiling (bound / best navigator) and the network's mean share of the bound."""
    out = []
    for source in SOURCES:
        for inside in (True, False):
            sel = [r for r in rows if r["source"] == source and r["inside"] == inside and r["ratio"] is not None]
            if not sel:
                continue
            shares = [r["one_item"]["share"] for r in sel if r.get("one_item", {}).get("share") is not None]
            entry = {"source": source, "budgets": "inside" if inside else "outside", "settings": len(sel),
                     "ratio_mean": float(np.mean([r["ratio"] for r in sel])),
                     "ratio_min": float(np.min([r["ratio"] for r in sel])),
                     "one_item_share_mean": float(np.mean(shares)) if shares else None}
            bounds = [r["bound"] for r in sel if (r.get("bound") or {}).get("ceiling") is not None]
            if bounds:
                entry.update(ceiling_mean=float(np.mean([b["ceiling"] for b in bounds])),
                             ceiling_min=float(np.min([b["ceiling"] for b in bounds])),
                             bound_share_mean=float(np.mean([b["net_share"] for b in bounds])))
            out.append(entry)
    return out


def run(learned, grid: list[Setting], total_reward: int = 30, episodes: int = 2000, seed: int = 0,
        optimum: bool = True, specialist: Callable[[Setting], Any] | None = None, greedy: bool = False,
        progress: Callable[[int, int, dict], None] | None = None, bound: bool = False) -> list[dict]:
    """:func:`evaluate_setting` over ``grid``; ``progress(i, n, row)`` after each row."""
    rows = []
    for i, setting in enumerate(grid):
        rows.append(evaluate_setting(learned, setting, total_reward, episodes, seed, optimum, specialist, greedy,
                                     bound))
        if progress is not None:
            progress(i + 1, len(grid), rows[-1])
    return rows


def heat_values(rows: list[dict], key: str = "ratio") -> tuple[list[list[float | None]], list[str], list[str]]:
    """``(values, map labels, budget labels)``: ``rows`` as a map x budget matrix of ``key`` (``"ratio"``, or
    ``"share"``: the one-item share of the optimum)."""
    maps = list(dict.fromkeys(f"{r['source']}: {r['map']}" if r["source"] != "thesis" else f"thesis {r['map']}"
                              for r in rows))
    budgets = list(dict.fromkeys(f"{r['energy'][0]:g}/{r['energy'][1]:g}" for r in rows))
    values: list[list[float | None]] = [[None] * len(budgets) for _ in maps]
    for r in rows:
        m = maps.index(f"{r['source']}: {r['map']}" if r["source"] != "thesis" else f"thesis {r['map']}")
        b = budgets.index(f"{r['energy'][0]:g}/{r['energy'][1]:g}")
        values[m][b] = r["ratio"] if key == "ratio" else (r.get("one_item") or {}).get("share")
    return values, maps, budgets


#: The thesis tables with a per-table ENN (section 4.5): the settings one general network should cover.
THESIS_TABLES = ("4.3", "4.4", "4.5", "4.6", "4.7", "4.8")


#: The grid size of the thesis' tables (Table 4.2: 8x8), on which :func:`thesis_tables` plays.
THESIS_GRID = 8


def thesis_tables(learned, episodes: int = 10_000, seed: int = 0, greedy: bool = False,
                  tables: tuple[str, ...] = THESIS_TABLES) -> list[dict]:
    """The network in the setting of each thesis table, against that table's ENN row (the thesis' per-table
    network): ``{table, risk, total_reward, energy, net {mean, se}, thesis_enn, z}`` with ``z`` the difference
    in standard errors of our mean (positive: above the thesis)."""
    from jaxdc.dcp.analysis.tables import TABLES

    rows = []
    for name in tables:
        spec = TABLES[name]
        env = DCP(grid_size=THESIS_GRID, total_reward=spec.total_reward, observation=learned.observation)
        params = instances.fixed_instance(env, spec.risk, spec.energy)
        m, se = _mean_se(evaluate_learned(env, params, learned, jax.random.PRNGKey(seed), episodes, greedy))
        thesis = spec.rows["enn"][0]
        rows.append({"table": name, "risk": spec.risk, "total_reward": spec.total_reward,
                     "energy": [float(e) for e in spec.energy], "net": {"mean": m, "se": se},
                     "thesis_enn": thesis, "z": (m - thesis) / se if se > 0 else None})
    return rows


def thesis_markdown(rows: list[dict]) -> str:
    """The thesis-table comparison as markdown."""
    lines = ["| table | setting | thesis ENN | this network | Δ / SE |", "|---|---|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['table']} | {r['risk']} risk, {r['total_reward']} items, "
                     f"{r['energy'][0]:g}/{r['energy'][1]:g} | {r['thesis_enn']:.2f} | "
                     f"{r['net']['mean']:.3f} ± {r['net']['se']:.3f} | {_f(r['z'], '+.1f')} |")
    return "\n".join(lines) + "\n"


def _f(x: float | None, fmt: str = ".2f") -> str:
    return "n/a" if x is None else format(x, fmt)


def markdown(rows: list[dict], command: str, network: str) -> str:
    """The grid as a markdown page section: every setting, then the summary by source and inside/outside (with
    the unlimited-energy bound's columns when the rows carry it)."""
    with_bound = any("bound" in r for r in rows)
    extra_head, extra_rule = (" bound | net / bound | ceiling |", "---:|---:|---:|") if with_bound else ("", "")
    lines = [f"Network `{network}`; `{command}`", "",
             "| map | budget | in range | net | best navigator | ratio | specialist | 1 item: net / optimum |"
             + extra_head, "|---|---|---|---:|---|---:|---:|---:|" + extra_rule]
    for r in rows:
        spec, one, best = r.get("specialist"), r.get("one_item"), r["best_navigator"]
        spec_text = "-" if spec is None else f"{spec['mean']:.2f}"
        one_text = "-" if one is None else f"{one['net']:.3f} / {one['optimum']:.3f} ({_f(one['share'])})"
        bound = r.get("bound")
        extra = "" if not with_bound else (" - | - | - |" if bound is None else
                                           f" {bound['mean']:.2f} | {_f(bound['net_share'], '.3f')} | "
                                           f"{_f(bound['ceiling'], '.3f')} |")
        lines.append(
            f"| {r['source']}: {r['map']} | {r['energy'][0]:g}/{r['energy'][1]:g} | {'yes' if r['inside'] else 'no'} "
            f"| {r['net']['mean']:.2f} ± {r['net']['se']:.2f} | {best['name']} {best['mean']:.2f} "
            f"| {_f(r['ratio'])} | {spec_text} | {one_text} |" + extra)
    summary = summarise(rows)
    with_ceiling = any("ceiling_mean" in s for s in summary)
    lines += ["", "| maps | budgets | settings | ratio mean | ratio min | 1-item share mean |"
              + (" ceiling mean | ceiling min | net / bound mean |" if with_ceiling else ""),
              "|---|---|---:|---:|---:|---:|" + ("---:|---:|---:|" if with_ceiling else "")]
    for s in summary:
        extra = "" if not with_ceiling else (
            f" {_f(s.get('ceiling_mean'), '.3f')} | {_f(s.get('ceiling_min'), '.3f')} | "
            f"{_f(s.get('bound_share_mean'), '.3f')} |")
        lines.append(f"| {s['source']} | {s['budgets']} | {s['settings']} | {s['ratio_mean']:.3f} | "
                     f"{s['ratio_min']:.3f} | {_f(s['one_item_share_mean'], '.3f')} |" + extra)
    return "\n".join(lines) + "\n"


__all__ = ["BUDGETS", "SOURCES", "THESIS_TABLES", "Setting", "evaluate_setting", "heat_values", "markdown",
           "one_item", "run", "settings", "summarise", "thesis_markdown", "thesis_tables", "training_range"]
