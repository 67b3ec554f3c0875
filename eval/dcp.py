"""Batched evaluation of DCP policies; reproduces the thesis' Tables 4.1 and 4.3-4.10 (heuristic rows).

Examples::

    python -m eval.dcp --policy safe_reward --risk high --total-reward 30 --energy 8 16 --episodes 10000 --seed 0
    python -m eval.dcp --table 4.3                 # the whole table, thesis beside ours
    python -m eval.dcp --table 4.1 --json          # one JSON object keyed by policy name
    python -m eval.dcp --policy safe_both --risk-map my_map.npy --energy 10 20

Results of ``--table`` are written atomically to ``--out`` (default
``results/dcp``) as ``table_<T>.json`` and ``table_<T>.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

from jaxdc.core import grid
from jaxdc.core.paths import PATH_RISK
from jaxdc.dcp import env as dcp_env
from jaxdc.dcp.navigators import POLICIES
from jaxdc.dcp.planners import CF_DISTANCES, PlannerConfig
from jaxdc.dcp.tables import TABLES
from jaxdc.io import atomic_write, atomic_write_json, enable_compilation_cache

COLUMNS = (("reward", 0), ("energy", 2), ("rpe", 4))


def _energy(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"energy must be a number or 'inf', got {text!r}") from None
    if math.isnan(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"energy must be > 0 (or 'inf'), got {text!r}")
    return value


def _positive_int(name):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be an integer >= 1, got {text!r}") from None
        if value < 1:
            raise argparse.ArgumentTypeError(f"{name} must be an integer >= 1, got {value}")
        return value

    return parse


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m eval.dcp", description=__doc__.split("\n\n")[0])
    what = p.add_mutually_exclusive_group()
    what.add_argument("--policy", choices=POLICIES + ("optimal",), default="safe_reward",
                      help="heuristic policy to evaluate; 'optimal' = exact value iteration (needs --total-reward 1)")
    what.add_argument("--table", choices=sorted(TABLES, key=lambda t: float(t)), help="reproduce a thesis table")
    p.add_argument("--risk", choices=sorted(grid.RISK_PRESETS), default="high", help="risk preset (Table 4.2)")
    p.add_argument("--risk-map", metavar="FILE", help="N x N risk map (.npy or JSON); overrides --risk")
    p.add_argument("--grid-size", type=_positive_int("--grid-size"), default=None, help="N (default 8, or the map's)")
    p.add_argument("--total-reward", type=_positive_int("--total-reward"), default=30)
    p.add_argument("--energy", nargs=2, type=_energy, metavar=("INIT", "MAX"), default=(8.0, 16.0),
                   help="initial and maximum energy; 'inf inf' for no constraint")
    p.add_argument("--episodes", type=_positive_int("--episodes"), default=10_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-steps", type=_positive_int("--max-steps"), default=1000, help="step cap (truncation)")
    # the thesis' ambiguities (docs/ambiguities.md)
    p.add_argument("--start", choices=dcp_env.STARTS, default="random_free")
    p.add_argument("--item-order", choices=dcp_env.ITEM_ORDERS, default="drop")
    p.add_argument("--energy-metric", choices=dcp_env.ENERGY_METRICS, default="not_stay_in_base")
    p.add_argument("--no-items-on-base", action="store_true", help="never drop items on the base cell")
    p.add_argument("--no-idle-stop", action="store_true",
                   help="do not end an episode whose step left the state unchanged (then only --max-steps ends it)")
    p.add_argument("--path-risk", choices=PATH_RISK, default="departed")
    p.add_argument("--cf-distance", choices=CF_DISTANCES, default="chebyshev")
    p.add_argument("--shortest-move", choices=grid.SHORTEST_MOVE_RULES, default="diagonal")
    p.add_argument("--lpg-init", type=float, default=0.0)
    p.add_argument("--rpe-zero", choices=("exclude", "zero"), default="exclude")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--out", default=os.path.join("results", "dcp"), help="folder for --table results")
    return p


def load_risk_map(path: str) -> np.ndarray:
    if not os.path.exists(path):
        raise ValueError(f"--risk-map: no such file {path!r}")
    try:
        if path.endswith(".npy"):
            arr = np.load(path)
        else:
            with open(path) as f:
                arr = np.asarray(json.load(f), dtype=np.float32)
    except (ValueError, OSError) as e:
        raise ValueError(f"--risk-map: cannot read {path!r} as .npy or JSON: {e}") from None
    try:
        return grid.validate_risk_map(arr)
    except (TypeError, ValueError) as e:
        raise ValueError(f"--risk-map {path!r}: {e}") from None


def evaluate_rows(args, spec=None, progress=None) -> dict:
    """Evaluate ``args.policy`` or every heuristic row of ``spec``; return ``{policy: summary}``."""
    import jax

    from jaxdc.dcp.evaluate import evaluate_heuristic, evaluate_optimal, summarize

    if args.risk_map:
        risk = load_risk_map(args.risk_map)
        n = args.grid_size or risk.shape[0]
    else:
        n = args.grid_size or 8
        risk = spec.risk if spec else args.risk
    total = spec.total_reward if spec else args.total_reward
    energy = spec.energy if spec else tuple(args.energy)
    env = dcp_env.DCP(
        grid_size=n,
        total_reward=total,
        start=args.start,
        items_on_base=not args.no_items_on_base,
        energy_metric=args.energy_metric,
        idle_terminates=not args.no_idle_stop,
        item_order=args.item_order,
    )
    params = env.make_params(risk, energy, max_steps=args.max_steps)
    cfg = PlannerConfig(cf_distance=args.cf_distance, shortest_move=args.shortest_move, lpg_init=args.lpg_init)
    policies = spec.heuristic_rows if spec else (args.policy,)
    out = {}
    for name in policies:
        t0 = time.perf_counter()
        key = jax.random.PRNGKey(args.seed)
        if name == "optimal":
            final, optimum = evaluate_optimal(env, params, key, args.episodes)
        else:
            final = evaluate_heuristic(env, params, name, key, args.episodes, cfg, args.path_risk)
        jax.block_until_ready(final)
        out[name] = summarize(final, args.rpe_zero)
        if name == "optimal":
            out[name]["expected_optimum"] = optimum
        out[name]["seconds"] = round(time.perf_counter() - t0, 3)
        if progress:
            progress(name, out[name])
    return out


def _fmt(x, digits):
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def markdown_table(spec, rows: dict, args) -> str:
    head = "| policy | reward (thesis) | reward (ours) | energy (thesis) | energy (ours) | RPE (thesis) | RPE (ours) | ours: outcomes |"
    lines = [head, "|" + "---|" * 8]
    for name, s in rows.items():
        th = spec.rows.get(name, (None,) * 6) if spec else (None,) * 6
        cells = [name]
        for col, i in COLUMNS:
            d = 3 if col == "rpe" else 2
            cells.append(f"{_fmt(th[i], d)} ± {_fmt(th[i + 1], d)}" if th[i] is not None else "—")
            cells.append(f"{_fmt(s[col]['mean'], d)} ± {_fmt(s[col]['sd'], d)}")
        cells.append(", ".join(f"{k} {v}" for k, v in s["outcomes"].items() if v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    enable_compilation_cache()
    spec = TABLES[args.table] if args.table else None
    if spec and args.risk_map:
        parser.error("--table runs the thesis' own setting; it cannot take --risk-map")
    try:
        if not args.json:
            what = f"Table {spec.name}: {spec.caption}" if spec else f"policy {args.policy}"
            print(f"Evaluating {what}, {args.episodes} episodes, seed {args.seed} ...", file=sys.stderr)

        def progress(name, s):
            if not args.json:
                print(f"  {name:14s} reward {s['reward']['mean']:.2f}  ({s['seconds']:.1f} s)", file=sys.stderr)

        rows = evaluate_rows(args, spec, progress)
    except (TypeError, ValueError) as e:
        parser.error(str(e))
    table = markdown_table(spec, rows, args)
    if spec:
        command = "python -m eval.dcp " + " ".join(argv if argv is not None else sys.argv[1:])
        payload = {"table": spec.name, "caption": spec.caption, "command": command,
                   "thesis": {k: list(v) for k, v in spec.rows.items()}, "ours": rows}
        atomic_write_json(os.path.join(args.out, f"table_{spec.name}.json"), payload)
        atomic_write(os.path.join(args.out, f"table_{spec.name}.md"),
                     f"### Table {spec.name}: {spec.caption}\n\n`{command}`\n\n{table}\n")
    if args.json:
        print(json.dumps(rows if spec else rows[args.policy]))
    else:
        print(table)
        if spec:
            print(f"\nwritten to {os.path.join(args.out, f'table_{spec.name}.json')} and .md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
