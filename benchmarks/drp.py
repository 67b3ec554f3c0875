"""DRP speed: jaxdc's jitted planners against a plain NumPy implementation of the same algorithms.

    python -m benchmarks.drp [--nodes 100] [--fig-graphs 2] [--fig-alphas 0,20,40,60] [--json]

1. One ``--nodes`` graph (thesis set-up, alpha = 20): every builder x clustering,
   jaxdc (first call with compilation, then warm) against the NumPy reference.
2. The figure-3.1 experiment on ``--fig-graphs`` graphs x ``--fig-alphas``
   (all 12 combinations), both ways; the full experiment (100 graphs x 17
   alphas) is extrapolated linearly in the number of instances and said so.
3. ``--nc-cache`` (instead of 1-2): NC variants side by side in one process, on
   ``--cc-graphs`` graphs of ``--cc-nodes`` nodes x ``--cc-alphas`` (default:
   the figure's 17 values), for ``--cc-builders``; checks the clusters are
   identical. ``--cc-rounds`` names the runs: ``cached``/``uncached`` (the
   append-builder tour cache on/off) and, for GI, ``resume``/``scratch`` (each
   union's tour resumed from the new cluster's GI trajectory, or rebuilt from
   scratch).

    python -m benchmarks.drp --nc-cache [--cc-graphs 3 --cc-nodes 100 --cc-builders ng,tl --json]
    python -m benchmarks.drp --nc-cache --cc-builders gi --cc-rounds resume,scratch,resume,scratch
    python -m benchmarks.drp --gi-resume-stats [--nodes 100 --alpha 20]   # why resume does not pay

4. ``--against REV`` (instead of 1-3): NC on ``--cc-graphs`` graphs x ``--cc-alphas``
   with the ``jaxdc`` (and ``eval``) of git revision ``REV`` (extracted with ``git archive``)
   and with the working tree's, each in a fresh process (first call with
   compilation, then warm), one after the other per builder; checks the
   clusters are identical.

    python -m benchmarks.drp --against bb1d1f1 --cc-graphs 2 --cc-builders gi,ng [--json]

5. ``--build-against REV`` (instead of 1-4): the six tour programs alone
   (``tours.build_order``, jitted and vmapped over ``B`` random ``K``-node
   clusters of a 100-node graph, best of 5 warm calls) of ``REV`` and of the
   working tree, fresh processes alternating old/new three times (best of
   the three per side); checks the tours are identical.

    python -m benchmarks.drp --build-against e10e983 --build-sizes 100x32,16x1024 [--json]

6. ``--fig-against REV`` (instead of 1-5): the figure-3.1 experiment (all 12
   combinations, ``jaxdc.drp.analysis.experiment.run_experiment``) on ``--cc-graphs`` graphs of
   ``--cc-nodes`` nodes x ``--cc-alphas``, with the ``jaxdc`` of ``REV`` and the
   working tree's, each in a fresh process run twice (first run with every
   compilation, then warm), one after the other; reports the total and
   per-part times and checks whether all rewards are *exactly* equal (else, per
   combination, how many instances differ and by how much at most) and whether
   they agree to float32 tolerance (relative 1e-5), and whether every plan
   (the tours of every combination and instance) is identical.

    python -m benchmarks.drp --fig-against 9dd8b83 --cc-graphs 4 --cc-nodes 100 [--json]

Every printed result (the last JSON on stdout; the progress lines on stderr
are not results) records where it came from under ``"provenance"``
(:func:`jaxdc.provenance.provenance`): an object gains the key, a list of rows
is printed as ``{"rows": [...], "provenance": {...}}``.

The reference uses the same formulas (Eqs. 3.2-3.8), NumPy-vectorised over
candidates within a step, Python loops over steps, NC re-evaluating only pairs
with the new cluster, and the same PGC (``jaxdc.drp.pgc_clustering.pgc`` is
already plain NumPy/Python).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from benchmarks.drp_against import build_against, figure_against, nc_against
from jaxdc.io import json_text

# ----------------------------------------------------------------------------- NumPy reference


def np_scores(criterion, P, beta, end, p_end, mask):
    """Eqs. 3.2-3.7 for every candidate, NumPy (higher is better)."""
    p_next = P[end]
    gain = p_end * p_next * beta
    after = p_end * p_next[:, None] * P * beta[None, :]
    delta = gain[None, :] - after
    other = mask[None, :] & mask[:, None] & ~np.eye(len(mask), dtype=bool)
    if criterion == "ng":
        s = gain
    elif criterion == "osa":
        two = np.where(other, after, -np.inf).max(1)
        s = gain + np.where(np.isfinite(two), two, 0.0)
    elif criterion == "tl":
        s = -np.where(other, delta, 0.0).sum(1)
    elif criterion == "gml":
        ml = np.where(other, delta, np.inf).min(1)
        s = gain - np.where(np.isfinite(ml), ml, 0.0)
    else:  # lpg
        tot = np.where(other, delta, 0.0).sum(1)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = -np.where(gain > 0, tot / np.where(gain > 0, gain, 1.0), np.finfo(np.float32).max)
    return np.where(mask, s, -np.inf)


def np_tour(criterion, P, beta, nodes):
    """Algorithm 2 over ``nodes``; returns (tour, reward)."""
    mask = np.zeros(len(beta), bool)
    mask[nodes] = True
    tour = []
    if criterion == "gi":
        for _ in range(len(nodes)):
            cyc = [0] + tour
            nxt = tour + [0]
            edge = P[cyc, nxt]
            reach = np.concatenate([[1.0], np.cumprod(edge)[:-1]])
            col = reach * beta[cyc]
            col[0] = 0.0
            after = col.sum() - np.cumsum(col) + np.prod(edge) * beta[0]
            pa, pb = P[cyc], P[nxt]
            s = reach[:, None] * pa * beta[None, :] - (1 - pa * pb / edge[:, None]) * after[:, None]
            s = np.where(mask[None, :], s, -np.inf)
            best = int(np.argmax(s.T))
            u, i = divmod(best, len(cyc))
            tour.insert(i, u)
            mask[u] = False
    else:
        end, p_end = 0, 1.0
        for _ in range(len(nodes)):
            u = int(np.argmax(np_scores(criterion, P, beta, end, p_end, mask)))
            tour.append(u)
            p_end *= P[end, u]
            end = u
            mask[u] = False
    r, prev, g = 1.0, 0, 0.0
    for v in tour:
        r *= P[prev, v]
        g += r * beta[v]
        prev = v
    return tour, g + r * P[prev, 0] * beta[0] - beta[0]


def np_nc(criterion, P, beta):
    """Algorithm 1 with BuildTour' as evaluator; only pairs with the new cluster are re-evaluated."""
    n = len(beta) - 1
    S = {v: [v] for v in range(1, n + 1)}
    R = {v: np_tour(criterion, P, beta, [v])[1] for v in S}
    pair = {(a, b): np_tour(criterion, P, beta, [a, b])[1] for a in S for b in S if a < b}
    while True:
        best, arg = 0.0, None
        for (a, b), r in sorted(pair.items()):
            d = r - R[a] - R[b]
            if d > best:
                best, arg = d, (a, b)
        if arg is None:
            return list(S.values())
        a, b = arg
        S[a] = sorted(S[a] + S.pop(b))
        R[a] = pair[(a, b)]
        pair = {k: v for k, v in pair.items() if a not in k and b not in k}
        for o in S:
            if o != a:
                lo, hi = min(a, o), max(a, o)
                pair[(lo, hi)] = np_tour(criterion, P, beta, S[lo] + S[hi])[1]


def np_solve(builder, clustering, D, beta, psi, alpha):
    from jaxdc.drp.pgc_clustering import pgc

    beta = np.asarray(beta, np.float64).copy()
    beta[0] = alpha
    P = float(psi) ** np.asarray(D, np.float64)
    clusters = np_nc(builder, P, beta) if clustering == "nc" else pgc(D, beta, psi, alpha).clusters
    rewards = [np_tour(builder, P, beta, c)[1] for c in clusters]
    return sum(r for r in rewards if r > 0)


# ----------------------------------------------------------------------------- benchmark


#: NC variants for :func:`nc_cache_compare`: keyword arguments of ``jaxdc.drp.nc_clustering.nc``.
NC_MODES = {"cached": {"cache": True}, "uncached": {"cache": False}, "resume": {"resume": True},
            "scratch": {"resume": False}}


def nc_cache_compare(graphs, nodes, alphas, builders, rounds=("cached", "uncached", "cached", "uncached")):
    """NC over ``graphs x alphas`` instances in the variants ``rounds`` (:data:`NC_MODES`), timed in one process.

    The first run of each path includes its compilation; a repeated path is timed warm.
    """
    bad = [r for r in rounds if r not in NC_MODES]
    if bad:
        raise ValueError(f"--cc-rounds must name runs from {sorted(NC_MODES)}, got {bad}")
    from jaxdc.drp import world
    from jaxdc.drp.nc_clustering import nc
    from jaxdc.drp.solve import graph_arrays

    gs = [world.generate(i, n=nodes) for i in range(graphs)]
    D, beta, psi = graph_arrays(gs)
    gidx = np.repeat(np.arange(graphs), len(alphas))
    al = np.tile(np.asarray(alphas, np.float32), graphs)
    rows = []
    for b in builders:
        members, row = {}, {"builder": b, "graphs": graphs, "nodes": nodes, "alphas": len(alphas)}
        for k, mode in enumerate(rounds):
            t0 = time.perf_counter()
            m = nc(b, D, beta, psi, gidx, al, **NC_MODES[mode])
            dt = time.perf_counter() - t0
            tag = mode + ("_warm" if mode in rounds[:k] else "_first")
            row[f"{tag}_s"] = dt
            if mode in members:
                assert (members[mode] == m).all()
            members[mode] = m
            print(json_text({"builder": b, tag: dt}, indent=None), file=sys.stderr)
        ms = list(members.values())
        row["identical_clusters"] = bool(all((x == ms[0]).all() for x in ms[1:]))
        rows.append(row)
    return rows


def gi_resume_stats(nodes=100, alpha=20.0, seed=0):
    """How much ``nc(..., resume=True)`` skips for GI on one graph: the share of resumed union builds that
    restart at step 0 and the share of insertions skipped (counted at NC's ``evaluate_clusters`` calls)."""
    from jaxdc.drp import nc_clustering as cl
    from jaxdc.drp import world
    from jaxdc.drp.solve import graph_arrays

    D, beta, psi = graph_arrays([world.generate(seed, n=nodes)])
    acc = {"jobs": 0, "restart_at_0": 0, "skipped": 0, "insertions": 0}
    inner = cl.evaluate_clusters

    def counted(*a, resume=None, **k):
        if resume is not None:
            done = np.asarray(resume[1])
            acc["jobs"] += len(done)
            acc["restart_at_0"] += int((done == 0).sum())
            acc["skipped"] += int(done.sum())
            acc["insertions"] += int(np.asarray(a[6]).sum())
        return inner(*a, resume=resume, **k)

    cl.evaluate_clusters = counted
    try:
        cl.nc("gi", D, beta, psi, np.array([0]), np.array([alpha], np.float32), resume=True)
    finally:
        cl.evaluate_clusters = inner
    return {**acc, "share_restart_at_0": acc["restart_at_0"] / acc["jobs"],
            "share_skipped": acc["skipped"] / acc["insertions"]}


def _build_sizes(text):
    """argparse type of ``--build-sizes``: ``KxB,...`` with 1 <= K <= 100 (the graph has 100 nodes),
    1 <= B <= 2**16."""
    try:
        sizes = [tuple(int(x) for x in kb.split("x")) for kb in text.split(",")]
    except ValueError:
        sizes = None
    if not sizes or any(len(s) != 2 or not 1 <= s[0] <= 100 or not 1 <= s[1] <= 2**16 for s in sizes):
        raise argparse.ArgumentTypeError(f"--build-sizes must be KxB,... with 1 <= K <= 100 and 1 <= B <= {2**16}, "
                                         f"got {text!r}")
    return sizes


def _alpha_list(name):
    """argparse type: comma-separated robot values, each a finite number in ``[0, VALUE_MAX]``."""
    from jaxdc.drp.world import VALUE_MAX

    def parse(text):
        try:
            vals = [float(a) for a in text.split(",")]
        except ValueError:
            vals = None
        if not vals or any(not 0.0 <= v <= VALUE_MAX for v in vals):  # NaN fails too
            raise argparse.ArgumentTypeError(f"{name} must be comma-separated finite numbers in [0, {VALUE_MAX:g}], "
                                             f"got {text!r}")
        return vals

    return parse


def _names(name, allowed):
    """argparse type: comma-separated names, each one of ``allowed``."""
    def parse(text):
        names = text.split(",")
        bad = [x for x in names if x not in allowed]
        if bad:
            raise argparse.ArgumentTypeError(f"{name} must be comma-separated names among {', '.join(allowed)}, "
                                             f"got {bad[0]!r}")
        return names

    return parse


def with_provenance(result, argv=None):
    """``result`` (an object or a list of rows) with the provenance of this run beside it; its command line is
    ``python -m benchmarks.drp ARGV`` (``argv=None``: ``sys.argv``)."""
    from jaxdc.provenance import provenance

    record = provenance(None if argv is None else ["python", "-m", "benchmarks.drp", *argv])
    if isinstance(result, dict):
        return {**result, "provenance": record}
    return {"rows": result, "provenance": record}


def main(argv=None):
    """The benchmark's exit status; every flag is checked (ranges, names) before any work."""
    from jaxdc.cli.runner import run

    return run(_main, "python -m benchmarks.drp", argv)


def _main(argv=None):
    from jaxdc.cli.args import nonnegative_float, positive_int
    from jaxdc.drp.tours import BUILDERS
    from jaxdc.drp.world import MAX_NODES, VALUE_MAX

    p = argparse.ArgumentParser(prog="python -m benchmarks.drp", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--nodes", type=positive_int("--nodes", MAX_NODES), default=100)
    p.add_argument("--alpha", type=nonnegative_float("--alpha", VALUE_MAX), default=20.0)
    p.add_argument("--fig-graphs", type=positive_int("--fig-graphs", 10**4), default=2)
    p.add_argument("--fig-nodes", type=positive_int("--fig-nodes", MAX_NODES), default=100)
    p.add_argument("--fig-alphas", type=_alpha_list("--fig-alphas"), default="0,20,40,60")
    p.add_argument("--skip-reference-nc", action="store_true", help="skip the slow NumPy NC solves")
    p.add_argument("--json", action="store_true")
    p.add_argument("--nc-cache", action="store_true", help="only the NC cached-vs-uncached comparison")
    p.add_argument("--cc-graphs", type=positive_int("--cc-graphs", 10**4), default=3)
    p.add_argument("--cc-nodes", type=positive_int("--cc-nodes", MAX_NODES), default=100)
    p.add_argument("--cc-alphas", type=_alpha_list("--cc-alphas"), default=",".join(str(5 * i) for i in range(17)))
    p.add_argument("--cc-builders", type=_names("--cc-builders", BUILDERS), default="ng,tl")
    p.add_argument("--cc-rounds", type=_names("--cc-rounds", tuple(NC_MODES)),
                   default="cached,uncached,cached,uncached", help="order of the runs; a repeated path is timed warm")
    p.add_argument("--gi-resume-stats", action="store_true",
                   help="only: how much NC+GI with resume=True skips on one --nodes graph at --alpha")
    p.add_argument("--against", metavar="REV",
                   help="only: NC with the jaxdc of git revision REV vs the working tree's (--cc-* settings)")
    p.add_argument("--build-against", metavar="REV",
                   help="only the tour programs of REV against the working tree's (see --build-sizes)")
    p.add_argument("--build-sizes", type=_build_sizes, default="100x32,16x1024",
                   help="comma-separated KxB: B clusters of K nodes (1 <= K <= 100, 1 <= B <= 65536) per call")
    p.add_argument("--fig-against", metavar="REV",
                   help="only: the figure-3.1 experiment with the jaxdc of REV vs the working tree's (--cc-graphs, "
                        "--cc-nodes, --cc-alphas)")
    args = p.parse_args(argv)
    dump = lambda obj: json_text(with_provenance(obj, argv), indent=None if args.json else 1)  # noqa: E731  strict JSON
    if args.build_against:
        rows = build_against(args.build_against, args.build_sizes)
        print(dump(rows))
        return
    if args.fig_against:
        row = figure_against(args.fig_against, args.cc_graphs, args.cc_nodes, args.cc_alphas)
        print(dump(row))
        return
    if args.against:
        rows = nc_against(args.against, args.cc_graphs, args.cc_nodes, args.cc_alphas, args.cc_builders)
        print(dump(rows))
        return
    if args.gi_resume_stats:
        print(json_text(with_provenance(gi_resume_stats(args.nodes, args.alpha), argv), indent=None))
        return
    if args.nc_cache:
        rows = nc_cache_compare(args.cc_graphs, args.cc_nodes, args.cc_alphas,
                                args.cc_builders, tuple(args.cc_rounds))
        print(dump(rows))
        return

    from jaxdc.drp import world
    from jaxdc.drp.analysis.experiment import run_experiment
    from jaxdc.drp.solve import graph_arrays, solve_instances
    from jaxdc.drp.tours import BUILDERS

    g = world.generate(0, n=args.nodes, alpha=args.alpha)
    D, beta, psi = graph_arrays([g])
    Dn, bn = np.asarray(D[0], np.float64), np.asarray(beta[0], np.float64)
    solves = []
    for c in ("nc", "pgc"):
        for b in BUILDERS:
            t0 = time.perf_counter()
            (r1, _), = solve_instances(b, c, D, beta, psi, [0], [args.alpha])
            first = time.perf_counter() - t0
            t0 = time.perf_counter()
            (r2, _), = solve_instances(b, c, D, beta, psi, [0], [args.alpha])
            warm = time.perf_counter() - t0
            row = {"builder": b, "clustering": c, "jax_first_s": first, "jax_warm_s": warm, "reward": r2}
            if not (c == "nc" and args.skip_reference_nc):
                t0 = time.perf_counter()
                rr = np_solve(b, c, Dn, bn, 0.99, args.alpha)
                row["numpy_s"] = time.perf_counter() - t0
                row["numpy_reward"] = rr
                row["speedup_warm"] = row["numpy_s"] / warm
            solves.append(row)
            if not args.json:
                print(json_text(row, indent=None), file=sys.stderr)

    alphas = args.fig_alphas
    t0 = time.perf_counter()
    run_experiment("4-6", args.fig_graphs, args.fig_nodes, alphas, "corner", 0, BUILDERS, ("nc", "pgc"), quiet=True)
    jax_fig = time.perf_counter() - t0
    t0 = time.perf_counter()
    gs = [world.generate(i, n=args.fig_nodes) for i in range(args.fig_graphs)]
    for gg in gs:
        Dg, bg, _ = world.arrays(gg)
        for a in alphas:
            for c in ("nc", "pgc"):
                for b in BUILDERS:
                    np_solve(b, c, np.asarray(Dg, np.float64), np.asarray(bg, np.float64), 0.99, a)
    np_fig = time.perf_counter() - t0
    inst = args.fig_graphs * len(alphas)
    full = 100 * 17
    out = {"nodes": args.nodes, "alpha": args.alpha, "solves": solves,
           "figure_3_1_reduced": {"graphs": args.fig_graphs, "nodes": args.fig_nodes, "alphas": alphas,
                                  "jax_s": jax_fig, "numpy_s": np_fig, "speedup": np_fig / jax_fig,
                                  "jax_extrapolated_full_s": jax_fig * full / inst,
                                  "numpy_extrapolated_full_s": np_fig * full / inst,
                                  "note": "full = 100 graphs x 17 alphas, linear extrapolation incl. one-off compile"}}
    print(dump(out))


if __name__ == "__main__":
    sys.exit(main())
