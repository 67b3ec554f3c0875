"""DRP command line: plan one graph, rerun the thesis' chapter-3 figures, optimality gaps.

    python -m eval.drp plan --graph FILE.json --builder gi --clustering pgc [--json] [--draw PLAN.png]
    python -m eval.drp figure 3.1 [--graphs 100 --nodes 100 --alphas 0,5,...,80 --base centre|corner]
    python -m eval.drp gaps [--graphs 200 --nodes 8]

Outputs go to ``results/drp/`` (JSON, CSV and PNG, each written atomically; a figure's JSON, CSV and PNG
land together). Every flag is checked before any work: counts are bounded (``--graphs``, ``--nodes``, the
memory the experiment needs), robot values are finite in ``[0, 1e9]``, seeds in ``[0, 2**32 - 1]`` (graph
``i`` uses ``seed + i``, which must stay in that range), and the output folder, every file a subcommand writes
into it (no folder or dangling symbolic link at its name) and the ``--draw`` file must be writable. Every
JSON written or printed is strict (no NaN or Infinity: an undefined statistic is ``null`` with a reason).
Ctrl-C exits 130 with one line; a bad input exits 2 with one line naming it.
"""

from __future__ import annotations

import argparse
import io
import os
import sys
from dataclasses import dataclass

from jaxdc.cli.args import positive_float, positive_int, seed
from jaxdc.cli.runner import run
from jaxdc.core.validate import SEED_MAX
from jaxdc.drp.analysis import cache
from jaxdc.drp.analysis.experiment import DEFAULT_ALPHAS, FIGURE_REWARDS, ExperimentConfig
from jaxdc.drp.exact.subset_dp import MAX_NODES as EXACT_MAX_NODES
from jaxdc.drp.solve import CLUSTERINGS
from jaxdc.drp.tours import BUILDERS
from jaxdc.drp.world import COORD_MAX, MAX_NODES, VALUE_MAX
from jaxdc.io import (
    atomic_write,
    atomic_write_set,
    check_output_folder,
    check_output_path,
    enable_compilation_cache,
    json_text,
)
from jaxdc.provenance import provenance

PROG = "python -m eval.drp"

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
    experiment: ExperimentConfig
    force: bool
    cache: bool
    workers: int
    quiet: bool
    markdown: bool


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


#: Most graphs of a figure or gaps run (graph ``i`` is generated from seed ``seed + i``).
MAX_GRAPHS = 10**6
#: Most robot values of one run.
MAX_ALPHAS = 1000
#: Most worker processes of a figure (more than one per builder are never used).
MAX_WORKERS = 64


def _png(text: str) -> str:
    if not text.lower().endswith(".png"):
        raise argparse.ArgumentTypeError(f"--draw must name a .png file, got {text!r}")
    return text


def _alpha_values(name, text):
    """Comma-separated robot values, each a finite number in ``[0, VALUE_MAX]`` (as floats)."""
    parts = text.split(",")
    if not text.strip() or len(parts) > MAX_ALPHAS:
        raise argparse.ArgumentTypeError(f"{name} must be 1 to {MAX_ALPHAS} comma-separated numbers in "
                                         f"[0, {VALUE_MAX:g}], got {text[:80]!r}")
    out = []
    for a in parts:
        try:
            v = float(a)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be comma-separated numbers in [0, {VALUE_MAX:g}], "
                                             f"got {a!r}") from None
        if not (0.0 <= v <= VALUE_MAX):  # NaN fails too
            raise argparse.ArgumentTypeError(f"{name} values must be finite numbers in [0, {VALUE_MAX:g}] "
                                             f"(robot values), got {a.strip()!r}")
        out.append(v)
    return out


def _figure_alphas(text):
    """``--alphas`` of ``figure``: whole numbers as ints, 0 always included, sorted."""
    vals = _alpha_values("--alphas", text)
    return tuple(sorted(set([0] + [int(a) if a.is_integer() else a for a in vals])))


def _gap_alphas(text):
    """``--alphas`` of ``gaps``: the robot values the graphs draw from (floats, order kept)."""
    return tuple(_alpha_values("--alphas", text))


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=OUT_DIR, help="output folder (default results/drp)")
    sub = p.add_subparsers(dest="cmd", required=True)
    pp = sub.add_parser("plan", help="plan one graph JSON file")
    pp.set_defaults(settle=_plan_settings, run=run_plan)
    pp.add_argument("--graph", required=True)
    pp.add_argument("--builder", choices=BUILDERS, default="gi")
    pp.add_argument("--clustering", choices=CLUSTERINGS, default="pgc")
    pp.add_argument("--json", action="store_true", help="print exactly one JSON object")
    pp.add_argument("--draw", metavar="PNG", type=_png, help="also draw the tours, one colour per robot, to this PNG")
    pf = sub.add_parser("figure", help="rerun a chapter-3 figure")
    pf.set_defaults(settle=_figure_settings, run=run_figure)
    pf.add_argument("figure", choices=sorted(FIGURE_REWARDS))
    pf.add_argument("--graphs", type=positive_int("--graphs", MAX_GRAPHS), default=100)
    pf.add_argument("--nodes", type=positive_int("--nodes", MAX_NODES), default=100)
    pf.add_argument("--alphas", type=_figure_alphas, default=",".join(map(str, DEFAULT_ALPHAS)),
                    help=f"robot values, comma-separated, each in [0, {VALUE_MAX:g}] (0 is always added)")
    pf.add_argument("--base", choices=("corner", "centre"), default="centre")
    pf.add_argument("--seed", type=seed("--seed"), default=0)
    pf.add_argument("--quick", action="store_true", help="10 graphs of 30 nodes")
    pf.add_argument("--force", action="store_true", help="recompute even if cached results exist")
    pf.add_argument("--cache", action="store_true",
                    help="persistent XLA compilation cache (~/.cache/jaxdc/xla; JAXDC_NO_CACHE=1 turns it off)")
    pf.add_argument("--workers", type=positive_int("--workers", MAX_WORKERS), default=min(os.cpu_count() or 1, 6),
                    help="processes, each taking a group of builders (default: one per CPU core, at most 6; "
                         "more than one per builder are not started)")
    pf.add_argument("--quiet", action="store_true")
    pf.add_argument("--markdown", action="store_true",
                    help="print the normalised mean (SD) and PGC/NC tables at alpha = 10..60 instead of the JSON line")
    pg = sub.add_parser("gaps", help="heuristics against the exact solver on small graphs")
    pg.set_defaults(settle=_gaps_settings, run=run_gaps)
    pg.add_argument("--graphs", type=positive_int("--graphs", MAX_GRAPHS), default=200)
    pg.add_argument("--nodes", type=positive_int("--nodes", EXACT_MAX_NODES), default=8,
                    help=f"nodes per graph, 1..{EXACT_MAX_NODES} (the exact solver's limit)")
    pg.add_argument("--size", type=positive_float("--size", high=COORD_MAX), default=40.0,
                    help="side of the square (small graphs need a small one)")
    pg.add_argument("--alphas", type=_gap_alphas, default="0,5,10,20,40",
                    help=f"robot values the graphs draw from, each in [0, {VALUE_MAX:g}]")
    pg.add_argument("--base", choices=("corner", "centre"), default="centre")
    pg.add_argument("--seed", type=seed("--seed"), default=0)
    pg.add_argument("--quiet", action="store_true")
    return p


def _plan_settings(args) -> PlanSettings:
    return PlanSettings(out=args.out, graph=args.graph, builder=args.builder, clustering=args.clustering,
                        json=args.json, draw=args.draw)


def _figure_settings(args) -> FigureSettings:
    graphs, nodes = (10, 30) if args.quick else (args.graphs, args.nodes)
    experiment = ExperimentConfig(rewards=FIGURE_REWARDS[args.figure], graphs=graphs, nodes=nodes,
                                  alphas=args.alphas, base=args.base, seed=args.seed)
    return FigureSettings(out=args.out, figure=args.figure, experiment=experiment, force=args.force,
                          cache=args.cache, workers=args.workers, quiet=args.quiet, markdown=args.markdown)


def _gaps_settings(args) -> GapsSettings:
    return GapsSettings(out=args.out, graphs=args.graphs, nodes=args.nodes, size=args.size, alphas=args.alphas,
                        base=args.base, seed=args.seed, quiet=args.quiet)


def settle(args) -> PlanSettings | FigureSettings | GapsSettings:
    """The parsed arguments as the settings record of their subcommand."""
    return args.settle(args)


def check_settings(p: argparse.ArgumentParser, s) -> None:
    """Refuse, before any work, settings the flags' own ranges let through: seeds past ``SEED_MAX`` for the
    later graphs, an experiment too big for the machine's memory, unwritable outputs."""
    counts = s.experiment if isinstance(s, FigureSettings) else s
    if isinstance(s, (FigureSettings, GapsSettings)) and counts.seed + counts.graphs - 1 > SEED_MAX:
        p.error(f"--seed {counts.seed} with --graphs {counts.graphs}: graph i uses seed + i, which must stay "
                f"<= {SEED_MAX}; lower --seed or --graphs")
    if isinstance(s, FigureSettings):
        from jaxdc.core.memory import check_fits

        # per process: NC (or the PGC plans) of all instances with one builder at a time; the workers run
        # at once, and the parent computes the PGC clusters meanwhile (jaxdc.drp.analysis.parallel)
        from jaxdc.drp.solve import plan_bytes

        e = s.experiment
        instances = e.graphs * len(e.alphas)
        one = max(plan_bytes(b, "nc", e.graphs, instances, e.nodes) for b in BUILDERS)
        needed = min(s.workers, len(BUILDERS)) * one + plan_bytes("gi", "pgc", e.graphs, instances, e.nodes)
        check_fits(needed, f"figure {s.figure} with --graphs {e.graphs} --nodes {e.nodes} --workers {s.workers}",
                   "--graphs or --nodes, or --workers")
    if isinstance(s, PlanSettings):
        inputs = {"--graph": s.graph}
        check_output_folder(s.out, "--out", files=(os.path.basename(plan_path(s)),), inputs=inputs)
        if s.draw:
            check_output_path(s.draw, "--draw", inputs)
    elif isinstance(s, FigureSettings):
        check_output_folder(s.out, "--out", files=[os.path.basename(f) for f in figure_paths(s)])
    else:
        check_output_folder(s.out, "--out", files=(os.path.basename(gaps_path(s)),))


def figure_paths(s: FigureSettings) -> tuple[str, str, str]:
    """The files ``figure`` writes: the experiment's JSON and CSV (``<out>/experiment_<tag>.{json,csv}``, written
    when it is computed) and the figure's PNG (``<out>/fig<N>_<tag>.png``). All three are checked before any
    work, even the two a stored experiment spares."""
    data = cache.experiment_path(s.out, s.experiment)
    return data, data[:-len(".json")] + ".csv", os.path.join(s.out, f"fig{s.figure.replace('.', '_')}_"
                                                                     f"{s.experiment.tag}.png")


def gaps_path(s: GapsSettings) -> str:
    """The JSON file ``gaps`` writes: ``<out>/gaps_n<nodes>_g<graphs>.json``."""
    return os.path.join(s.out, f"gaps_n{s.nodes}_g{s.graphs}.json")


def plan_path(s: PlanSettings) -> str:
    """The plan's JSON file: ``<out>/plan_<graph name>_<builder>_<clustering>.json``."""
    name = os.path.splitext(os.path.basename(s.graph))[0]
    return os.path.join(s.out, f"plan_{name}_{s.builder}_{s.clustering}.json")


# ----------------------------------------------------------------------------- plan


def run_plan(s: PlanSettings) -> int:
    from jaxdc.drp import world
    from jaxdc.drp.solve import graph_arrays, plan_bytes, solve_instances

    try:
        graph = world.load(s.graph)
    except (ValueError, TypeError, OSError) as e:
        print(f"{PROG}: error: --graph {s.graph}: {e}", file=sys.stderr)
        return 2
    from jaxdc.core.memory import check_fits

    n = len(graph.nodes)
    check_fits(plan_bytes(s.builder, s.clustering, 1, 1, n),
               f"planning the {n}-node graph of --graph {s.graph} with --builder {s.builder} "
               f"--clustering {s.clustering}", "the number of nodes in the graph file")
    D, beta, psi = graph_arrays([graph])
    (reward, tours), = solve_instances(s.builder, s.clustering, D, beta, psi, [0], [graph.alpha])
    result = {"expected_reward": float(reward), "robots": len(tours), "tours": tours}
    text = json_text({**result, "provenance": provenance()}, indent=None)  # the file records where it came from
    if not s.draw:
        atomic_write(plan_path(s), text)
    if s.json:
        print(json_text(result, indent=None))
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
        atomic_write_set({plan_path(s): text, s.draw: buf.getvalue()})
        if not s.json:
            print(f"tours drawn to {s.draw}")
    return 0


# ----------------------------------------------------------------------------- figures


def _warn(message: str) -> None:
    print(f"{PROG}: {message}", file=sys.stderr)


def run_figure(s: FigureSettings) -> int:
    from jaxdc.drp.analysis.summary import markdown_tables, rows_csv
    from jaxdc.viewer.curves import draw_curves

    if s.cache:
        enable_compilation_cache()
    alphas = list(s.experiment.alphas)
    data_path, csv_path, png = figure_paths(s)
    stored = None if s.force else cache.stored_experiment(data_path, s.experiment, warn=_warn)
    files = {}
    if stored is None:
        stored = cache.compute_experiment(s.experiment, workers=s.workers, xla_cache=s.cache, quiet=s.quiet)
        files[data_path] = json_text({**stored, "provenance": provenance()}, indent=None)
        files[csv_path] = rows_csv(stored["rows"])
    buf = io.BytesIO()
    draw_curves(stored["rows"], alphas, BUILDERS, s.figure).savefig(buf, format="png", dpi=80)
    files[png] = buf.getvalue()
    atomic_write_set(files)
    if s.markdown:
        show = [a for a in alphas if a in MARKDOWN_ALPHAS] or alphas
        print(markdown_tables(stored["rows"], show, BUILDERS))
    else:
        print(json_text({"figure": s.figure, "data": data_path, "png": png,
                         "wall_seconds": round(stored["wall_seconds"], 1)}, indent=None))
    return 0


# ----------------------------------------------------------------------------- optimality gaps


def run_gaps(s: GapsSettings) -> int:
    from jaxdc.drp.analysis.gaps import gap_graphs, optimality_gaps

    rows = optimality_gaps(gap_graphs(s.graphs, s.nodes, s.size, list(s.alphas), s.base, s.seed), quiet=s.quiet)
    out = {"config": {"graphs": s.graphs, "nodes": s.nodes, "size": s.size, "alphas": list(s.alphas),
                      "base": s.base, "seed": s.seed}, "rows": rows, "provenance": provenance()}
    atomic_write(gaps_path(s), json_text(out, indent=1))
    for r in rows:
        if r["mean_ratio"] is None:
            print(f"{r['clustering']:>3} {r['builder']:>3}: n/a ({r['undefined']})")
            continue
        print(f"{r['clustering']:>3} {r['builder']:>3}: mean heuristic/optimal {r['mean_ratio']:.4f}, "
              f"worst {r['min_ratio']:.4f}, optimal on {100 * r['optimal_share']:.0f}% of {r['graphs']} graphs")
    return 0


def _main(argv=None) -> int:
    p = build_parser()
    args = p.parse_args(argv)
    s = settle(args)
    check_settings(p, s)
    return args.run(s)


def main(argv=None) -> int:
    """The command line's exit status: 0, 2 for a bad flag or input (one line on stderr), 130 on Ctrl-C."""
    return run(_main, PROG, argv)
