"""DRP command line: plan one graph, rerun the thesis' chapter-3 figures, optimality gaps.

    python -m eval.drp plan --graph FILE.json --builder gi --clustering pgc [--json] [--draw PLAN.png]
    python -m eval.drp figure 3.1 [--graphs 100 --nodes 100 --alphas 0,5,...,80 --base centre|corner]
    python -m eval.drp gaps [--graphs 200 --nodes 8]

Outputs go to ``results/drp/`` (JSON, CSV and PNG, each written atomically).
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import os
import sys
import time

import numpy as np

from jaxdc.cli.args import positive_int
from jaxdc.io import atomic_write, enable_compilation_cache

FIGURE_REWARDS = {"3.1": "4-6", "3.2": "4-6", "3.3": "4-6", "3.4": "1-9", "3.5": "5"}
DEFAULT_ALPHAS = tuple(range(0, 85, 5))
OUT_DIR = os.path.join("results", "drp")


# ----------------------------------------------------------------------------- solving


def solve_instances(builder, clustering, D, beta, psi, gidx, alphas, progress=None):
    """Plans for many instances (graph ``gidx[i]`` at robot value ``alphas[i]``): ``[(reward, tours)]``."""
    from jaxdc.drp import clustering as cl

    gidx = np.asarray(gidx)
    alphas = np.asarray(alphas, np.float32)
    if clustering == "nc":
        member = cl.nc(builder, D, beta, psi, gidx, alphas, progress=progress)
        clusters = [cl.clusters_from_member(m) for m in member]
    elif clustering == "pgc":
        clusters = pgc_clusters(D, beta, psi, gidx, alphas, progress)
    else:
        raise ValueError(f"clustering must be one of {cl.CLUSTERINGS}, got {clustering!r}")
    return cl.plan_tours(builder, D, beta, psi, gidx, alphas, clusters)


def pgc_clusters(D, beta, psi, gidx, alphas, progress=None):
    from jaxdc.drp import clustering as cl

    Dn, bn, pn = np.asarray(D, np.float64), np.asarray(beta, np.float64), np.asarray(psi, np.float64)
    out = []
    for g, a in zip(gidx, alphas):
        out.append(cl.pgc(Dn[g], bn[g], pn[g], float(a))[0])
        if progress is not None:
            progress()
    return out


def graph_arrays(graphs):
    import jax.numpy as jnp

    from jaxdc.drp import world

    D = jnp.stack([world.distances(g.base, g.nodes) for g in graphs])
    beta = jnp.stack([world.node_values(g.rewards, g.alpha) for g in graphs])
    psi = jnp.asarray([g.psi for g in graphs], jnp.float32)
    return D, beta, psi


# ----------------------------------------------------------------------------- plan


def cmd_plan(args):
    from jaxdc.drp import world

    try:
        graph = world.load(args.graph)
    except (ValueError, TypeError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    D, beta, psi = graph_arrays([graph])
    (reward, tours), = solve_instances(args.builder, args.clustering, D, beta, psi, [0], [graph.alpha])
    result = {"expected_reward": float(reward), "robots": len(tours), "tours": tours}
    name = os.path.splitext(os.path.basename(args.graph))[0]
    atomic_write(os.path.join(args.out, f"plan_{name}_{args.builder}_{args.clustering}.json"), json.dumps(result))
    if args.json:
        print(json.dumps(result))
    else:
        print(f"builder={args.builder} clustering={args.clustering}: {len(tours)} robot(s), "
              f"expected reward {reward:.4f}")
        for i, t in enumerate(tours, 1):
            print(f"  robot {i}: 0 -> {' -> '.join(map(str, t))} -> 0")
    if args.draw:
        from jaxdc.viewer import draw_plan

        buf = io.BytesIO()
        draw_plan(graph, tours, title=f"{args.builder.upper()} + {args.clustering.upper()}: {len(tours)} robot(s), "
                                      f"expected reward {reward:.3f}").savefig(buf, format="png", dpi=100)
        atomic_write(args.draw, buf.getvalue())
        if not args.json:
            print(f"tours drawn to {args.draw}")
    return 0


def _png(text: str) -> str:
    if not text.lower().endswith(".png"):
        raise argparse.ArgumentTypeError(f"must name a .png file, got {text!r}")
    return text


# ----------------------------------------------------------------------------- figures


def experiment_arrays(rewards, graphs, nodes, alphas, base, seed):
    """The section 3.5 instances: ``(D, beta, psi)`` of the generated graphs and ``(gidx, alpha)`` per instance."""
    from jaxdc.drp import world

    gs = [world.generate(seed + i, n=nodes, rewards=rewards, base=base) for i in range(graphs)]
    D, beta, psi = graph_arrays(gs)
    return D, beta, psi, np.repeat(np.arange(graphs), len(alphas)), np.tile(np.asarray(alphas, np.float32), graphs)


def pgc_plans(builders, D, beta, psi, gidx, alphas, clusters, raw, timing):
    """Algorithm 6's tours on the PGC ``clusters`` with each builder: fills ``raw[("pgc", b)]``
    (``[graphs, alphas]`` rewards, instances graph-major) and ``timing[f"pgc_{b}"]``."""
    from jaxdc.drp import clustering as cl

    n_alpha = int(np.sum(gidx == gidx[0]))
    for b in builders:
        t0 = time.perf_counter()
        res = cl.plan_tours(b, D, beta, psi, gidx, alphas, clusters)
        raw[("pgc", b)] = np.asarray([r for r, _ in res]).reshape(-1, n_alpha)
        timing[f"pgc_{b}"] = time.perf_counter() - t0


def progress_units(builders, clusterings, nodes, instances):
    """The progress bar's length: ``nodes + 1`` NC merge rounds per builder (an upper bound; the rest is
    added when NC stops) and one unit per PGC instance."""
    return len(builders) * ("nc" in clusterings) * (nodes + 1) + ("pgc" in clusterings) * instances


def run_experiment(rewards, graphs, nodes, alphas, base, seed, builders, clusterings, quiet=False, progress=None):
    """The section 3.5 experiment: per (clustering, builder, alpha) the expected reward of each graph.

    The progress bar counts NC merge rounds (``nodes + 1`` per builder) and PGC instances;
    ``progress(k)``, if given, is called with those units instead of drawing a bar.
    """
    from tqdm import tqdm

    D, beta, psi, gidx, al = experiment_arrays(rewards, graphs, nodes, alphas, base, seed)
    raw, timing = {}, {}
    total = progress_units(builders, clusterings, nodes, len(gidx))
    with tqdm(total=total, desc=f"DRP rewards {rewards}", disable=quiet or progress is not None,
              file=sys.stderr) as bar:
        advance = progress or bar.update
        if "pgc" in clusterings:
            t0 = time.perf_counter()
            clusters = pgc_clusters(D, beta, psi, gidx, al, progress=lambda: advance(1))
            timing["pgc_clustering"] = time.perf_counter() - t0
            pgc_plans(builders, D, beta, psi, gidx, al, clusters, raw, timing)
        if "nc" in clusterings:
            for b in builders:
                t0 = time.perf_counter()
                done = [0]

                def tick():
                    done[0] += 1
                    if done[0] <= nodes:
                        advance(1)

                res = solve_instances(b, "nc", D, beta, psi, gidx, al, progress=tick)
                advance(nodes + 1 - min(done[0], nodes))
                raw[("nc", b)] = np.asarray([r for r, _ in res]).reshape(graphs, len(alphas))
                timing[f"nc_{b}"] = time.perf_counter() - t0
    return raw, timing


#: Relative cost of NC with each builder (NC + GI = 1), from the per-part times of the full figure-3.1 run
#: (100 graphs x 100 nodes, docs/drp.md); only used to balance the processes.
NC_COST = {"gi": 1.0, "gml": 0.50, "osa": 0.34, "lpg": 0.24, "tl": 0.24, "ng": 0.17}


def builder_groups(builders, workers):
    """Split ``builders`` over at most ``workers`` processes, heaviest first onto the lightest process."""
    groups = [[] for _ in range(min(workers, len(builders)))]
    load = [0.0] * len(groups)
    for b in sorted(builders, key=lambda b: -NC_COST.get(b, 1.0)):
        i = load.index(min(load))
        groups[i].append(b)
        load[i] += NC_COST.get(b, 1.0)
    return groups


def _worker(task):
    """One process: NC with its builders, then PGC plans with them on the clusters the parent sends.
    Progress (NC rounds) goes to the parent through ``ticks``."""
    cache, clusters_q, ticks, rewards, graphs, nodes, alphas, base, seed, builders, clusterings = task
    if cache:
        enable_compilation_cache()
    raw, timing = {}, {}
    if "nc" in clusterings:
        raw, timing = run_experiment(rewards, graphs, nodes, alphas, base, seed, builders, ("nc",),
                                     progress=ticks.put)
    if "pgc" in clusterings:
        D, beta, psi, gidx, al = experiment_arrays(rewards, graphs, nodes, alphas, base, seed)
        pgc_plans(builders, D, beta, psi, gidx, al, clusters_q.get(), raw, timing)
    return raw, timing


def run_parallel(workers, rewards, graphs, nodes, alphas, base, seed, cache, quiet,
                 builders=None, clusterings=("nc", "pgc")):
    """:func:`run_experiment` split over processes: each worker takes a group of builders
    (:func:`builder_groups`) for NC and for the PGC plans, and compiles only their programs;
    the parent computes the PGC clusters (pure Python) meanwhile and sends them to every worker.
    Same results as :func:`run_experiment` (tests/test_drp_cli.py)."""
    import multiprocessing as mp
    import queue as queue_mod
    from concurrent.futures import ProcessPoolExecutor

    from tqdm import tqdm

    from jaxdc.drp.tours import BUILDERS

    builders = list(builders or BUILDERS)
    groups = builder_groups(builders, workers)
    ctx = mp.get_context("spawn")
    raw, timing = {}, {}
    total = progress_units(builders, clusterings, nodes, graphs * len(alphas))
    with ctx.Manager() as manager, ProcessPoolExecutor(len(groups), mp_context=ctx) as pool, \
            tqdm(total=total, desc=f"DRP rewards {rewards} ({len(groups)} processes)", disable=quiet,
                 file=sys.stderr) as bar:
        clusters_q, ticks = manager.Queue(), manager.Queue()

        def drain(block=False):
            try:
                while True:
                    bar.update(ticks.get(timeout=0.5) if block else ticks.get_nowait())
                    block = False
            except queue_mod.Empty:
                pass

        futures = [pool.submit(_worker, (cache, clusters_q, ticks, rewards, graphs, nodes, alphas, base, seed, g,
                                         clusterings)) for g in groups]
        if "pgc" in clusterings:
            D, beta, psi, gidx, al = experiment_arrays(rewards, graphs, nodes, alphas, base, seed)
            t0 = time.perf_counter()
            clusters = pgc_clusters(D, beta, psi, gidx, al, progress=lambda: (bar.update(1), drain()))
            timing["pgc_clustering"] = time.perf_counter() - t0
            for _ in groups:
                clusters_q.put(clusters)
        while not all(f.done() for f in futures):
            drain(block=True)
        drain()
        for f in futures:
            r, t = f.result()
            raw.update(r)
            timing.update(t)
    return dict(sorted(raw.items())), timing


def summarise(raw, alphas):
    """Normalised mean and SD (section 3.5.1): divided by the mean reward at alpha = 0."""
    i0 = list(alphas).index(0)
    norm = float(np.mean(next(iter(raw.values()))[:, i0]))
    rows = []
    for (c, b), r in raw.items():
        for k, a in enumerate(alphas):
            row = {"clustering": c, "builder": b, "alpha": a, "mean": float(r[:, k].mean() / norm),
                   "sd": float(r[:, k].std() / norm)}
            if c == "pgc" and ("nc", b) in raw:
                nc_mean = raw[("nc", b)][:, k].mean()
                row["pgc_over_nc"] = float(r[:, k].mean() / nc_mean) if nc_mean > 0 else None
            rows.append(row)
    return norm, rows


def markdown_tables(rows, alphas, builders):
    """The experiment's normalised mean (SD) per clustering and PGC/NC as markdown tables, builders in the
    thesis' order of quality (GI, TL, LPG, OSA, GML, NG), at ``alphas``."""
    order = [b for b in ("gi", "tl", "lpg", "osa", "gml", "ng") if b in builders]
    at = {(r["clustering"], r["builder"], r["alpha"]): r for r in rows}

    def head(title):
        return [f"| {title} | " + " | ".join(f"α={a:g}" for a in alphas) + " |", "|---|" + "---|" * len(alphas)]

    out = []
    for c in ("nc", "pgc"):
        if not any((c, b, a) in at for b in order for a in alphas):
            continue
        out += head(f"{c.upper()} mean (SD)")
        out += [f"| {b.upper()} | " + " | ".join(f"{at[c, b, a]['mean']:.3f} ({at[c, b, a]['sd']:.3f})"
                                                for a in alphas) + " |" for b in order]
        out.append("")
    if any(("pgc", b, a) in at and ("nc", b, a) in at for b in order for a in alphas):
        out += head("PGC / NC")
        out += [f"| {b.upper()} | " + " | ".join("–" if at["pgc", b, a].get("pgc_over_nc") is None else
                                                f"{at['pgc', b, a]['pgc_over_nc']:.2f}" for a in alphas) + " |"
                for b in order]
    return "\n".join(out)


def _plot(rows, alphas, builders, figure, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = {"3.1": [("nc", "mean"), ("nc", "sd")], "3.2": [("pgc", "mean"), ("pgc", "sd")],
              "3.3": [("pgc", "pgc_over_nc")]}.get(figure, [("nc", "mean"), ("pgc", "mean"), ("pgc", "pgc_over_nc")])
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.4), squeeze=False)
    labels = {"mean": "normalised mean reward", "sd": "normalised SD", "pgc_over_nc": "PGC / NC"}
    for ax, (c, key) in zip(axes[0], panels):
        for b in builders:
            ys = [next((r[key] for r in rows if r["clustering"] == c and r["builder"] == b and r["alpha"] == a),
                       None) for a in alphas]
            ys = [np.nan if y is None else y for y in ys]
            ax.plot(alphas, ys, marker="o", ms=3, label=b.upper())
        ax.set_xlabel("robot value α")
        ax.set_ylabel(labels[key])
        ax.set_title(f"{'PGC' if c == 'pgc' else 'NC'}: {labels[key]}" if key != "pgc_over_nc" else "PGC / NC")
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.suptitle(f"Figure {figure} (ours)")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    atomic_write(path, buf.getvalue())


def cmd_figure(args):
    from jaxdc.drp.tours import BUILDERS

    rewards = FIGURE_REWARDS[args.figure]
    alphas = sorted(set([0] + [int(a) if float(a).is_integer() else float(a) for a in args.alphas.split(",")]))
    if args.quick:
        args.graphs, args.nodes = 10, 30
    if args.cache:
        enable_compilation_cache()
    config = {"rewards": rewards, "graphs": args.graphs, "nodes": args.nodes, "alphas": alphas,
              "base": args.base, "seed": args.seed}
    tag = f"r{rewards}_g{args.graphs}_n{args.nodes}_{args.base}_s{args.seed}"
    data_path = os.path.join(args.out, f"experiment_{tag}.json")
    cached = None
    if os.path.exists(data_path) and not args.force:
        with open(data_path) as f:
            cached = json.load(f)
        if cached.get("config") != config:
            cached = None
    if cached is None:
        t0 = time.perf_counter()
        if args.workers > 1:
            raw, timing = run_parallel(args.workers, rewards, args.graphs, args.nodes, alphas, args.base,
                                       args.seed, args.cache, args.quiet)
        else:
            raw, timing = run_experiment(rewards, args.graphs, args.nodes, alphas, args.base, args.seed,
                                         BUILDERS, ("nc", "pgc"), quiet=args.quiet)
        wall = time.perf_counter() - t0
        norm, rows = summarise(raw, alphas)
        cached = {"config": config, "wall_seconds": wall, "timing": timing, "normaliser": norm, "rows": rows,
                  "raw": {f"{c}_{b}": r.tolist() for (c, b), r in raw.items()}}
        atomic_write(data_path, json.dumps(cached))
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=["clustering", "builder", "alpha", "mean", "sd", "pgc_over_nc"])
        w.writeheader()
        for r in rows:
            w.writerow(r)
        atomic_write(data_path[:-5] + ".csv", buf.getvalue())
    png = os.path.join(args.out, f"fig{args.figure.replace('.', '_')}_{tag}.png")
    _plot(cached["rows"], alphas, BUILDERS, args.figure, png)
    if args.markdown:
        show = [a for a in alphas if a in (10, 20, 30, 40, 50, 60)] or alphas
        print(markdown_tables(cached["rows"], show, BUILDERS))
    else:
        print(json.dumps({"figure": args.figure, "data": data_path, "png": png,
                          "wall_seconds": round(cached["wall_seconds"], 1)}))
    return 0


# ----------------------------------------------------------------------------- optimality gaps


def cmd_gaps(args):
    from tqdm import tqdm

    from jaxdc.drp import exact, world
    from jaxdc.drp.tours import BUILDERS

    alphas = [float(a) for a in args.alphas.split(",")]
    rng = np.random.default_rng(args.seed)
    gs = [world.generate(args.seed + i, n=args.nodes, rewards="4-6", base=args.base, size=args.size,
                         alpha=float(rng.choice(alphas))) for i in range(args.graphs)]
    D, beta, psi = graph_arrays(gs)
    opt = np.asarray([exact.solve(np.asarray(D[i]), np.asarray(beta[i]), 0.99)[0]
                      for i in tqdm(range(len(gs)), desc="exact", file=sys.stderr, disable=args.quiet)])
    gidx = np.arange(len(gs))
    al = np.asarray([g.alpha for g in gs])
    rows = []
    for c in ("nc", "pgc"):
        for b in BUILDERS:
            got = np.asarray([r for r, _ in solve_instances(b, c, D, beta, psi, gidx, al)])
            ok = opt > 1e-9
            ratio = got[ok] / opt[ok]
            rows.append({"clustering": c, "builder": b, "mean_ratio": float(ratio.mean()),
                         "min_ratio": float(ratio.min()), "optimal_share": float(np.mean(ratio > 1 - 1e-4)),
                         "graphs": int(ok.sum())})
    out = {"config": {"graphs": args.graphs, "nodes": args.nodes, "size": args.size, "alphas": alphas,
                      "base": args.base, "seed": args.seed}, "rows": rows}
    atomic_write(os.path.join(args.out, f"gaps_n{args.nodes}_g{args.graphs}.json"), json.dumps(out, indent=1))
    for r in rows:
        print(f"{r['clustering']:>3} {r['builder']:>3}: mean heuristic/optimal {r['mean_ratio']:.4f}, "
              f"worst {r['min_ratio']:.4f}, optimal on {100 * r['optimal_share']:.0f}% of {r['graphs']} graphs")
    return 0


def main(argv=None):
    from jaxdc.drp.tours import BUILDERS

    p = argparse.ArgumentParser(prog="python -m eval.drp", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=OUT_DIR, help="output folder (default results/drp)")
    sub = p.add_subparsers(dest="cmd", required=True)
    pp = sub.add_parser("plan", help="plan one graph JSON file")
    pp.add_argument("--graph", required=True)
    pp.add_argument("--builder", choices=BUILDERS, default="gi")
    pp.add_argument("--clustering", choices=("nc", "pgc"), default="pgc")
    pp.add_argument("--json", action="store_true", help="print exactly one JSON object")
    pp.add_argument("--draw", metavar="PNG", type=_png, help="also draw the tours, one colour per robot, to this PNG")
    pf = sub.add_parser("figure", help="rerun a chapter-3 figure")
    pf.add_argument("figure", choices=sorted(FIGURE_REWARDS))
    pf.add_argument("--graphs", type=int, default=100)
    pf.add_argument("--nodes", type=int, default=100)
    pf.add_argument("--alphas", default=",".join(map(str, DEFAULT_ALPHAS)))
    pf.add_argument("--base", choices=("corner", "centre"), default="centre")
    pf.add_argument("--seed", type=int, default=0)
    pf.add_argument("--quick", action="store_true", help="10 graphs of 30 nodes")
    pf.add_argument("--force", action="store_true", help="recompute even if cached results exist")
    pf.add_argument("--cache", action="store_true", help="persistent XLA compilation cache (~/.cache/jaxdc/xla; JAXDC_NO_CACHE=1 turns it off)")
    pf.add_argument("--workers", type=positive_int("--workers"), default=min(os.cpu_count() or 1, 6),
                    help="processes, each taking a group of builders (default: one per CPU core, at most 6)")
    pf.add_argument("--quiet", action="store_true")
    pf.add_argument("--markdown", action="store_true",
                    help="print the normalised mean (SD) and PGC/NC tables at alpha = 10..60 instead of the JSON line")
    pg = sub.add_parser("gaps", help="heuristics against the exact solver on small graphs")
    pg.add_argument("--graphs", type=int, default=200)
    pg.add_argument("--nodes", type=int, default=8)
    pg.add_argument("--size", type=float, default=40.0, help="side of the square (small graphs need a small one)")
    pg.add_argument("--alphas", default="0,5,10,20,40")
    pg.add_argument("--base", choices=("corner", "centre"), default="centre")
    pg.add_argument("--seed", type=int, default=0)
    pg.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    if getattr(args, "graphs", 1) < 1 or getattr(args, "nodes", 1) < 1:
        p.error("--graphs and --nodes must be >= 1")
    return {"plan": cmd_plan, "figure": cmd_figure, "gaps": cmd_gaps}[args.cmd](args)


if __name__ == "__main__":
    sys.exit(main())
