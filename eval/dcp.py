"""Batched evaluation of DCP policies; reproduces the thesis' Tables 4.1 and 4.3-4.10 (navigators and learners).

Examples::

    python -m eval.dcp --policy safe_reward --risk high --total-reward 30 --energy 8 16 --episodes 10000 --seed 0
    python -m eval.dcp --policy enn --risk high --episodes 10000 --json   # the shipped ENN (Table 4.3 setting)
    python -m eval.dcp --policy eqn --checkpoint runs/dcp-eqn-high-s0     # a train.dcp run folder
    python -m eval.dcp --table 4.3                 # the whole table with the learned row, thesis beside ours
    python -m eval.dcp --table 4.7 --checkpoint my_enn.msgpack            # the learned row from an exported file
    python -m eval.dcp --table 4.1 --json          # one JSON object keyed by policy name
    python -m eval.dcp --policy safe_both --risk-map my_map.npy --energy 10 20

A learned policy (``--policy enn|linear|cnn|eqn``) is the shipped parameter
file trained in the requested risk/energy setting (``jaxdc/assets/dcp``), or
``--checkpoint PATH`` (a ``train.dcp`` run folder or a ``.msgpack`` file).
Its environment settings come from the file's metadata unless given; it is
played in the environment it was trained in (no idle stop, as in
``train.dcp``). Actor-critics sample from their policy (section 4.5; ``--greedy``
for the argmax), EQN is epsilon-greedy with ``--epsilon`` 0.05 (section 4.5.5).

``--table`` fills the learned row of Tables 4.3-4.10 (ENN; the linear learner
in 4.9, EQN in 4.10) and the incr.% columns: the learner's increment over each
navigator as a percentage of the navigator's mean. As in the thesis, the ENN of
Table 4.3 also plays Tables 4.6 and 4.8; Table 4.7 has its own ENN (energy 16/32).
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

from jaxdc.cli.args import positive_float, positive_int, unit_interval
from jaxdc.core import grid
from jaxdc.core.paths import PATH_RISK
from jaxdc.dcp import env as dcp_env
from jaxdc.dcp import learned as learned_lib
from jaxdc.dcp.navigators import POLICIES
from jaxdc.dcp.planners import CF_DISTANCES, PlannerConfig
from jaxdc.dcp.tables import TABLES, incr_percent
from jaxdc.io import atomic_write, atomic_write_json, enable_compilation_cache

COLUMNS = (("reward", 0), ("energy", 2), ("rpe", 4))
#: Settings of a heuristic evaluation when not given (a learned one takes them from its metadata).
DEFAULTS = {"risk": "high", "total_reward": 30, "energy": (8.0, 16.0), "max_steps": 1000}


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m eval.dcp", description=__doc__.split("\n\n")[0])
    what = p.add_mutually_exclusive_group()
    what.add_argument("--policy", choices=POLICIES + ("optimal",) + learned_lib.NETS, default="safe_reward",
                      help="heuristic policy to evaluate; 'optimal' = exact value iteration (needs --total-reward 1); "
                           "enn/linear/cnn/eqn = a learned network (shipped, or --checkpoint)")
    what.add_argument("--table", choices=sorted(TABLES, key=lambda t: float(t)), help="reproduce a thesis table")
    p.add_argument("--checkpoint", metavar="PATH",
                   help="learned parameters: a train.dcp run folder or a .msgpack file (jaxdc.pretrained); "
                        "with --table, the table's learned row")
    p.add_argument("--run-seed", type=int, default=None, metavar="S",
                   help="--checkpoint of a train.dcp --seeds run: the seed whose network to evaluate")
    p.add_argument("--greedy", action="store_true",
                   help="learned policy: argmax instead of sampling (EQN: epsilon 0)")
    p.add_argument("--epsilon", type=unit_interval("--epsilon"), default=learned_lib.EQN_EPSILON,
                   help="EQN's evaluation epsilon (section 4.5.5: 0.05)")
    p.add_argument("--no-learned", action="store_true", help="--table: navigator rows only")
    p.add_argument("--risk", choices=sorted(grid.RISK_PRESETS), default=None,
                   help="risk preset (Table 4.2; default high, or the learned network's)")
    p.add_argument("--risk-map", metavar="FILE", help="N x N risk map (.npy or JSON); overrides --risk")
    p.add_argument("--grid-size", type=positive_int("--grid-size"), default=None,
                   help="N (default 8, the map's, or the learned network's)")
    p.add_argument("--total-reward", type=positive_int("--total-reward"), default=None,
                   help="default 30, or the learned network's")
    p.add_argument("--energy", nargs=2, type=positive_float("--energy", allow_inf=True), metavar=("INIT", "MAX"),
                   default=None,
                   help="initial and maximum energy; 'inf inf' for no constraint (default 8 16, or the learned "
                        "network's)")
    p.add_argument("--episodes", type=positive_int("--episodes"), default=10_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=None,
                   help="step cap (truncation; default 1000, or the learned network's)")
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


def resolve_learned(args, spec=None):
    """The learned network to evaluate (``None`` if none): ``--checkpoint``, or the shipped one of the setting.

    For ``--table`` it is the table's learner (ENN; linear in 4.9, EQN in 4.10)
    trained in the table's risk and energy (the thesis reuses the ENN of Table
    4.3 for Tables 4.6 and 4.8, whose total reward differs); a shipped file
    that is missing leaves the row out (``None``) and says so on stderr.
    """
    if args.run_seed is not None and not args.checkpoint:
        raise ValueError(f"--run-seed {args.run_seed} needs --checkpoint (a train.dcp --seeds run folder)")
    if spec is None:
        if args.policy not in learned_lib.NETS:
            if args.checkpoint:
                raise ValueError(f"--checkpoint needs --policy one of {learned_lib.NETS} or --table, "
                                 f"got --policy {args.policy}")
            return None
        if args.checkpoint:
            return learned_lib.load(args.checkpoint, net=args.policy, grid_size=args.grid_size,
                                    run_seed=args.run_seed)
        return learned_lib.shipped(args.policy, args.risk or DEFAULTS["risk"], args.energy or DEFAULTS["energy"],
                                   grid_size=args.grid_size)
    if not spec.learned or args.no_learned:
        if args.checkpoint:
            raise ValueError(f"--checkpoint: Table {spec.name} has no learned row" if not spec.learned
                             else "--checkpoint and --no-learned exclude each other")
        return None
    net = spec.learned[0]
    if not args.checkpoint:
        try:
            return learned_lib.shipped(net, spec.risk, spec.energy, grid_size=args.grid_size)
        except ValueError as e:
            print(f"warning: Table {spec.name}: learned row {net} left out: {e}", file=sys.stderr)
            return None
    learned = learned_lib.load(args.checkpoint, net=net, grid_size=args.grid_size, run_seed=args.run_seed)
    have = learned.setting()
    if have["risk"] != spec.risk or tuple(map(float, have["energy"])) != tuple(map(float, spec.energy)):
        raise ValueError(f"--checkpoint {args.checkpoint}: Table {spec.name} needs a {net} trained with risk "
                         f"{spec.risk!r} and energy {spec.energy[0]:g}/{spec.energy[1]:g}; this one was trained "
                         f"with risk {have['risk']!r} and energy {have['energy'][0]:g}/{have['energy'][1]:g}")
    return learned


def evaluation_setting(args, spec=None, learned=None) -> dict:
    """Grid size, risk, total reward, energy and step cap of the evaluation.

    A thesis table fixes risk, total reward and energy; otherwise each comes
    from the command line, else from the learned network's metadata, else
    from :data:`DEFAULTS`.
    """
    s = dict(DEFAULTS, grid_size=None)
    if learned is not None:
        s.update(learned.setting())
    if spec is not None:
        s.update(risk=spec.risk, total_reward=spec.total_reward, energy=spec.energy)
    else:
        given = {"risk": args.risk, "total_reward": args.total_reward, "energy": args.energy}
        s.update({k: v for k, v in given.items() if v is not None})
    if args.max_steps is not None:
        s["max_steps"] = args.max_steps
    if args.risk_map:
        s["risk"] = load_risk_map(args.risk_map)
        s["grid_size"] = args.grid_size or s["risk"].shape[0]
    else:
        s["grid_size"] = args.grid_size or s["grid_size"] or 8
    if learned is not None and s["grid_size"] != learned.setting()["grid_size"]:
        g = learned.setting()["grid_size"]
        raise ValueError(f"{learned.source} was trained on a {g}x{g} grid; it cannot play a "
                         f"{s['grid_size']}x{s['grid_size']} grid")
    s["energy"] = tuple(float(e) for e in s["energy"])
    return s


def make_env(args, setting: dict, learned=None):
    """The DCP of the evaluation; a learned network plays the dynamics it was trained with (no idle stop)."""
    options = dict(start=args.start, items_on_base=not args.no_items_on_base, energy_metric=args.energy_metric,
                   idle_terminates=not args.no_idle_stop, item_order=args.item_order)
    if learned is not None:
        options.update(idle_terminates=False)
        options.update(learned.env_options())
    env = dcp_env.DCP(grid_size=setting["grid_size"], total_reward=setting["total_reward"], **options)
    return env, env.make_params(setting["risk"], setting["energy"], max_steps=setting["max_steps"])


def evaluate_rows(args, spec=None, progress=None, learned=None) -> dict:
    """Evaluate ``args.policy`` or every row of ``spec`` (navigators, then ``learned``); return ``{policy: summary}``."""
    import jax

    from jaxdc.dcp.evaluate import evaluate_heuristic, evaluate_learned, evaluate_optimal, summarize

    setting = evaluation_setting(args, spec, learned)
    cfg = PlannerConfig(cf_distance=args.cf_distance, shortest_move=args.shortest_move, lpg_init=args.lpg_init)
    if spec:
        policies = spec.heuristic_rows + ((learned.net_name,) if learned is not None else ())
    else:
        policies = (args.policy,)
    out = {}
    for name in policies:
        t0 = time.perf_counter()
        key = jax.random.PRNGKey(args.seed)
        if name in learned_lib.NETS:
            env, params = make_env(args, setting, learned)
            final = evaluate_learned(env, params, learned, key, args.episodes, args.greedy, args.epsilon, cfg,
                                     args.path_risk)
        elif name == "optimal":
            env, params = make_env(args, setting)
            final, optimum = evaluate_optimal(env, params, key, args.episodes)
        else:
            env, params = make_env(args, setting)
            final = evaluate_heuristic(env, params, name, key, args.episodes, cfg, args.path_risk)
        jax.block_until_ready(final)
        out[name] = summarize(final, args.rpe_zero)
        if name == "optimal":
            out[name]["expected_optimum"] = optimum
        out[name]["seconds"] = round(time.perf_counter() - t0, 3)
        if progress:
            progress(name, out[name])
    return out


def incr_rows(spec, rows: dict, learner: str | None) -> dict:
    """``{navigator: {column: (thesis incr.%, ours incr.%)}}``: the learner's increment over each navigator."""
    if learner is None or learner not in rows:
        return {}
    out = {}
    for name in spec.heuristic_rows:
        th_l, th_n = spec.rows.get(learner), spec.rows.get(name)
        out[name] = {col: [incr_percent(th_l[i], th_n[i]) if th_l and th_n else None,
                           incr_percent(rows[learner][col]["mean"], rows[name][col]["mean"])]
                     for col, i in COLUMNS}
    return out


def _fmt(x, digits):
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def markdown_table(spec, rows: dict, args, incr: dict | None = None) -> str:
    head = ("| policy | reward (thesis) | reward (ours) | energy (thesis) | energy (ours) | RPE (thesis) | RPE (ours) "
            "| ours: outcomes |")
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
    if incr:
        lines += ["", incr_markdown(incr)]
    return "\n".join(lines)


def incr_markdown(incr: dict) -> str:
    """The incr.% columns (learner over each navigator, % of the navigator's mean), thesis beside ours."""
    lines = ["| incr.% over | reward (thesis) | reward (ours) | energy (thesis) | energy (ours) | RPE (thesis) "
             "| RPE (ours) |", "|" + "---|" * 7]
    for name, cols in incr.items():
        cells = [name] + [_fmt(v, 2) for col, _ in COLUMNS for v in cols[col]]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def learned_info(learned) -> dict:
    """What the results JSON says about a learned row: network, source and how it was trained."""
    meta = learned.metadata
    info = {"net": learned.net_name, "source": os.path.relpath(learned.source) if os.path.isabs(learned.source)
            else learned.source, "trained": learned.setting()}
    info.update({k: meta[k] for k in ("steps", "seed", "command") if k in meta})
    return info


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    enable_compilation_cache()
    spec = TABLES[args.table] if args.table else None
    if spec and args.risk_map:
        parser.error("--table runs the thesis' own setting; it cannot take --risk-map")
    if spec:
        given = [f for f, v in (("--risk", args.risk), ("--total-reward", args.total_reward),
                                ("--energy", args.energy)) if v is not None]
        if given:
            parser.error(f"--table runs the thesis' own setting; it cannot take {', '.join(given)}")
    try:
        if args.energy is not None:
            dcp_env.check_energy(args.energy)
        learned = resolve_learned(args, spec)
        if not args.json:
            what = f"Table {spec.name}: {spec.caption}" if spec else f"policy {args.policy}"
            print(f"Evaluating {what}, {args.episodes} episodes, seed {args.seed} ...", file=sys.stderr)
            if learned is not None:
                print(f"  learned: {learned_lib.describe(learned)}", file=sys.stderr)

        def progress(name, s):
            if not args.json:
                print(f"  {name:14s} reward {s['reward']['mean']:.2f}  ({s['seconds']:.1f} s)", file=sys.stderr)

        rows = evaluate_rows(args, spec, progress, learned)
    except (TypeError, ValueError) as e:
        parser.error(str(e))
    incr = incr_rows(spec, rows, learned.net_name if learned is not None else None) if spec else {}
    table = markdown_table(spec, rows, args, incr)
    if spec:
        command = "python -m eval.dcp " + " ".join(argv if argv is not None else sys.argv[1:])
        payload = {"table": spec.name, "caption": spec.caption, "command": command,
                   "thesis": {k: list(v) for k, v in spec.rows.items()}, "ours": rows, "incr": incr,
                   "learned": learned_info(learned) if learned is not None else None}
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
