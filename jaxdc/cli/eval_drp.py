"""DRP command line: plan one graph, rerun the thesis' chapter-3 figures, optimality gaps.

    python -m eval.drp plan --graph FILE.json --builder gi --clustering pgc [--json] [--draw PLAN.png]
    python -m eval.drp figure 3.1 [--graphs 100 --nodes 100 --alphas 0,5,...,80 --base centre|corner]
    python -m eval.drp gaps [--graphs 200 --nodes 8]

Outputs go to ``results/drp/`` (JSON, CSV and PNG, each written atomically).
"""

from __future__ import annotations

import argparse
import io
import json
import os
import sys
import time
from dataclasses import dataclass

from jaxdc.cli.args import positive_int
from jaxdc.drp.experiment import DEFAULT_ALPHAS, FIGURE_REWARDS
from jaxdc.drp.solve import CLUSTERINGS
from jaxdc.drp.tours import BUILDERS
from jaxdc.io import atomic_write, enable_compilation_cache

OUT_DIR = os.path.join("results", "drp")
#: The robot values the ``--markdown`` tables show (those of the figure's alphas among them).
MARKDOWN_ALPHAS = (10, 20, 30, 40, 50, 60)


@dataclass(frozen=True)
class PlanSettings:
    """``plan``: one graph file, solved with one builder and clustering."""

    out: str
    graph: str
    builder: str
    clustering: str
    json: bool
    draw: str | None


@dataclass(frozen=True)
class FigureSettings:
    """``figure``: the section 3.5 experiment behind a chapter-3 figure."""

    out: str
    figure: str
    rewards: str
    graphs: int
    nodes: int
    alphas: tuple
    base: str
    seed: int
    force: bool
    cache: bool
    workers: int
    quiet: bool
    markdown: bool

    @property
    def config(self) -> dict:
        """The experiment's settings as stored with its results (a stored run is reused only if they match)."""
        return {"rewards": self.rewards, "graphs": self.graphs, "nodes": self.nodes, "alphas": list(self.alphas),
                "base": self.base, "seed": self.seed}

    @property
    def tag(self) -> str:
        return f"r{self.rewards}_g{self.graphs}_n{self.nodes}_{self.base}_s{self.seed}"


@dataclass(frozen=True)
class GapsSettings:
    """``gaps``: heuristics against the exact solver on small graphs."""

    out: str
    graphs: int
    nodes: int
    size: float
    alphas: tuple
    base: str
    seed: int
    quiet: bool


def _png(text: str) -> str:
    if not text.lower().endswith(".png"):
        raise argparse.ArgumentTypeError(f"must name a .png file, got {text!r}")
    return text


def _figure_alphas(text):
    """``--alphas`` of ``figure``: whole numbers as ints, 0 always included, sorted."""
    return tuple(sorted(set([0] + [int(a) if float(a).is_integer() else float(a) for a in text.split(",")])))


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m eval.drp", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=OUT_DIR, help="output folder (default results/drp)")
    sub = p.add_subparsers(dest="cmd", required=True)
    pp = sub.add_parser("plan", help="plan one graph JSON file")
    pp.add_argument("--graph", required=True)
    pp.add_argument("--builder", choices=BUILDERS, default="gi")
    pp.add_argument("--clustering", choices=CLUSTERINGS, default="pgc")
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
    return p


def settle(args):
    """The parsed arguments as the settings record of their subcommand."""
    if args.cmd == "plan":
        return PlanSettings(args.out, args.graph, args.builder, args.clustering, args.json, args.draw)
    if args.cmd == "figure":
        graphs, nodes = (10, 30) if args.quick else (args.graphs, args.nodes)
        return FigureSettings(args.out, args.figure, FIGURE_REWARDS[args.figure], graphs, nodes,
                              _figure_alphas(args.alphas), args.base, args.seed, args.force, args.cache, args.workers,
                              args.quiet, args.markdown)
    return GapsSettings(args.out, args.graphs, args.nodes, args.size, tuple(float(a) for a in args.alphas.split(",")),
                        args.base, args.seed, args.quiet)


# ----------------------------------------------------------------------------- plan


def run_plan(s: PlanSettings) -> int:
    from jaxdc.drp import world
    from jaxdc.drp.solve import graph_arrays, solve_instances

    try:
        graph = world.load(s.graph)
    except (ValueError, TypeError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    D, beta, psi = graph_arrays([graph])
    (reward, tours), = solve_instances(s.builder, s.clustering, D, beta, psi, [0], [graph.alpha])
    result = {"expected_reward": float(reward), "robots": len(tours), "tours": tours}
    name = os.path.splitext(os.path.basename(s.graph))[0]
    atomic_write(os.path.join(s.out, f"plan_{name}_{s.builder}_{s.clustering}.json"), json.dumps(result))
    if s.json:
        print(json.dumps(result))
    else:
        print(f"builder={s.builder} clustering={s.clustering}: {len(tours)} robot(s), "
              f"expected reward {reward:.4f}")
        for i, t in enumerate(tours, 1):
            print(f"  robot {i}: 0 -> {' -> '.join(map(str, t))} -> 0")
    if s.draw:
        from jaxdc.viewer import draw_plan

        buf = io.BytesIO()
        draw_plan(graph, tours, title=f"{s.builder.upper()} + {s.clustering.upper()}: {len(tours)} robot(s), "
                                      f"expected reward {reward:.3f}").savefig(buf, format="png", dpi=100)
        atomic_write(s.draw, buf.getvalue())
        if not s.json:
            print(f"tours drawn to {s.draw}")
    return 0


# ----------------------------------------------------------------------------- figures


def _stored_experiment(path, config, force):
    """The stored results at ``path`` if they exist, were made with ``config`` and ``force`` is off."""
    if not os.path.exists(path) or force:
        return None
    with open(path) as f:
        stored = json.load(f)
    return stored if stored.get("config") == config else None


def _compute_experiment(s: FigureSettings) -> dict:
    from jaxdc.drp.experiment import run_experiment
    from jaxdc.drp.parallel import run_parallel
    from jaxdc.drp.summary import experiment_record

    alphas = list(s.alphas)
    t0 = time.perf_counter()
    if s.workers > 1:
        raw, timing = run_parallel(s.workers, s.rewards, s.graphs, s.nodes, alphas, s.base, s.seed, s.cache, s.quiet)
    else:
        raw, timing = run_experiment(s.rewards, s.graphs, s.nodes, alphas, s.base, s.seed, BUILDERS, CLUSTERINGS,
                                     quiet=s.quiet)
    return experiment_record(s.config, raw, timing, time.perf_counter() - t0, alphas)


def run_figure(s: FigureSettings) -> int:
    from jaxdc.drp.summary import markdown_tables, rows_csv
    from jaxdc.viewer.curves import draw_curves

    if s.cache:
        enable_compilation_cache()
    alphas = list(s.alphas)
    data_path = os.path.join(s.out, f"experiment_{s.tag}.json")
    stored = _stored_experiment(data_path, s.config, s.force)
    if stored is None:
        stored = _compute_experiment(s)
        atomic_write(data_path, json.dumps(stored))
        atomic_write(data_path[:-5] + ".csv", rows_csv(stored["rows"]))
    png = os.path.join(s.out, f"fig{s.figure.replace('.', '_')}_{s.tag}.png")
    buf = io.BytesIO()
    draw_curves(stored["rows"], alphas, BUILDERS, s.figure).savefig(buf, format="png", dpi=80)
    atomic_write(png, buf.getvalue())
    if s.markdown:
        show = [a for a in alphas if a in MARKDOWN_ALPHAS] or alphas
        print(markdown_tables(stored["rows"], show, BUILDERS))
    else:
        print(json.dumps({"figure": s.figure, "data": data_path, "png": png,
                          "wall_seconds": round(stored["wall_seconds"], 1)}))
    return 0


# ----------------------------------------------------------------------------- optimality gaps


def run_gaps(s: GapsSettings) -> int:
    from jaxdc.drp.gaps import gap_graphs, optimality_gaps

    rows = optimality_gaps(gap_graphs(s.graphs, s.nodes, s.size, list(s.alphas), s.base, s.seed), quiet=s.quiet)
    out = {"config": {"graphs": s.graphs, "nodes": s.nodes, "size": s.size, "alphas": list(s.alphas),
                      "base": s.base, "seed": s.seed}, "rows": rows}
    atomic_write(os.path.join(s.out, f"gaps_n{s.nodes}_g{s.graphs}.json"), json.dumps(out, indent=1))
    for r in rows:
        print(f"{r['clustering']:>3} {r['builder']:>3}: mean heuristic/optimal {r['mean_ratio']:.4f}, "
              f"worst {r['min_ratio']:.4f}, optimal on {100 * r['optimal_share']:.0f}% of {r['graphs']} graphs")
    return 0


def main(argv=None) -> int:
    p = build_parser()
    args = p.parse_args(argv)
    if getattr(args, "graphs", 1) < 1 or getattr(args, "nodes", 1) < 1:
        p.error("--graphs and --nodes must be >= 1")
    s = settle(args)
    return {PlanSettings: run_plan, FigureSettings: run_figure, GapsSettings: run_gaps}[type(s)](s)
