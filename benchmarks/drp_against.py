"""DRP speed against an older revision: the ``--against``, ``--build-against`` and ``--fig-against`` modes of
``python -m benchmarks.drp`` (its docstring, points 4-6).

Each side runs in a fresh process: the ``jaxdc`` (and ``eval``) of git revision ``REV``, extracted with
``git archive`` into a temporary folder and put first on ``sys.path``, and the working tree's; the children
below write their timings and results to an ``.npz`` that the parent compares.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from jaxdc.io import json_text


def _nc_child(builder, graphs, nodes, alphas, out):
    """Child of :func:`nc_against`: NC twice (first call, warm) with whichever ``jaxdc`` is first on ``sys.path``."""
    import jax.numpy as jnp

    from jaxdc.drp import nc, world  # the package's names, the same in every revision compared

    gs = [world.generate(i, n=nodes) for i in range(graphs)]
    D = jnp.stack([world.distances(g.base, g.nodes) for g in gs])
    beta = jnp.stack([world.node_values(g.rewards, g.alpha) for g in gs])
    psi = jnp.asarray([g.psi for g in gs], jnp.float32)
    gidx = np.repeat(np.arange(graphs), len(alphas))
    al = np.tile(np.asarray(alphas, np.float32), graphs)
    times = []
    for _ in range(2):
        t0 = time.perf_counter()
        member = nc(builder, D, beta, psi, gidx, al)
        times.append(time.perf_counter() - t0)
    np.savez(out, member=member, first=times[0], warm=times[1])


def _against(rev, child, tags):
    """Run ``child(root, tag, out)`` -- a Python statement -- once with the ``jaxdc`` and ``eval`` of git
    revision ``rev`` (``git archive`` into a temporary folder) and once with the working tree's, each in a
    fresh process; yields ``(tag, npz contents)``."""
    import os
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        old = os.path.join(tmp, "old")
        os.makedirs(old)
        archive = subprocess.run(["git", "archive", rev, "jaxdc", "eval"], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", old], input=archive, check=True)
        here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        for tag in tags:
            for side, root in (("old", old), ("new", here)):
                out = os.path.join(tmp, f"{tag}_{side}.npz")
                code = f"import sys; sys.path.insert(0, {root!r}); " + child(tag, out)
                subprocess.run([sys.executable, "-c", code], check=True, cwd=here)
                with np.load(out) as z:
                    yield tag, side, {k: z[k] for k in z.files}


def nc_against(rev, graphs, nodes, alphas, builders):
    """NC with the ``jaxdc`` of git revision ``rev`` and with the working tree's, side by side (fresh processes)."""
    rows = {b: {"builder": b, "graphs": graphs, "nodes": nodes, "alphas": len(alphas), "against": rev}
            for b in builders}
    members = {}
    child = lambda b, out: (f"from benchmarks.drp_against import _nc_child; "  # noqa: E731
                            f"_nc_child({b!r}, {graphs}, {nodes}, {list(alphas)!r}, {out!r})")
    for b, side, z in _against(rev, child, builders):
        row = rows[b]
        members[b, side] = z["member"]
        row[f"{side}_first_s"], row[f"{side}_warm_s"] = float(z["first"]), float(z["warm"])
        print(json_text({"builder": b, side: [row[f"{side}_first_s"], row[f"{side}_warm_s"]]}, indent=None),
              file=sys.stderr)
        if side == "new":
            row["speedup_first"] = row["old_first_s"] / row["new_first_s"]
            row["speedup_warm"] = row["old_warm_s"] / row["new_warm_s"]
            row["identical_clusters"] = bool((members[b, "old"] == members[b, "new"]).all())
    return list(rows.values())


def _fig_child(graphs, nodes, alphas, out):
    """Child of :func:`figure_against`: the figure-3.1 experiment twice (first run, warm) with whichever
    ``jaxdc`` is first on ``sys.path``; rewards and times to ``out``."""
    from jaxdc.drp.tours import BUILDERS

    try:
        from jaxdc.drp import plans as plans_mod
        from jaxdc.drp import solve

        try:
            from jaxdc.drp.analysis import experiment
        except ImportError:  # a revision before the DRP's analysis/ folder
            from jaxdc.drp import experiment

        run_experiment, inner, callers = experiment.run_experiment, plans_mod.plan_tours, (experiment, solve)
    except ImportError:  # a revision that keeps the experiment in eval.drp and the plans in jaxdc.drp.clustering
        from eval.drp import run_experiment
        from jaxdc.drp import clustering

        inner, callers = clustering.plan_tours, (clustering,)
    plans = []

    def recorded(criterion, *args, **kwargs):  # every plan's tours, in call order (same in both versions)
        out = inner(criterion, *args, **kwargs)
        plans.append([criterion, [tours for _, tours in out]])
        return out

    for module in callers:
        module.plan_tours = recorded
    res = {}
    for run in ("first", "warm"):
        plans.clear()
        t0 = time.perf_counter()
        raw, timing = run_experiment("4-6", graphs, nodes, alphas, "centre", 0, BUILDERS, ("nc", "pgc"), quiet=True)
        res[f"{run}_s"] = time.perf_counter() - t0
        res.update({f"{run}_t_{k}": v for k, v in timing.items()})
    res.update({f"raw_{c}_{b}": r for (c, b), r in raw.items()})
    res["plans"] = np.asarray(json.dumps(plans))
    np.savez(out, **res)


def _build_child(K, B, out):
    """Child of :func:`build_against`: each builder's vmapped tour program on ``B`` random ``K``-node clusters of
    a 100-node graph, best of 5 warm calls, with whichever ``jaxdc`` is first on ``sys.path``."""
    import jax
    import jax.numpy as jnp

    from jaxdc.drp import tours, world

    D, beta, psi = world.arrays(world.generate(1, n=100, rewards="4-6", alpha=40.0))
    P = psi ** D
    rng = np.random.default_rng(0)
    subs = np.stack([np.concatenate([[0], np.sort(rng.choice(np.arange(1, 101), K, replace=False))])
                     for _ in range(B)])
    Ps, bs = jnp.asarray(P[subs[:, :, None], subs[:, None, :]]), jnp.asarray(beta[subs])
    ms = jnp.ones((B, K + 1), bool)
    res = {}
    for b in tours.BUILDERS:
        f = jax.jit(jax.vmap(lambda P, beta, m, b=b: tours.build_order(b, P, beta, m)))
        res[f"tours_{b}"] = np.asarray(f(Ps, bs, ms))
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            f(Ps, bs, ms).block_until_ready()
            times.append(time.perf_counter() - t0)
        res[f"ms_{b}"] = 1e3 * min(times)
    np.savez(out, **res)


def build_against(rev, sizes, rounds=3):
    """The tour programs alone (``tours.build_order``, vmapped) of ``rev`` and of the working tree, for each
    ``(K, B)`` in ``sizes``: milliseconds per call (the best over ``rounds`` alternating old/new fresh processes,
    so that a load change on the machine hits both sides) and whether the tours are identical."""
    from jaxdc.drp.tours import BUILDERS

    tags = [f"{K}x{B}r{r}" for K, B in sizes for r in range(rounds)]
    child = lambda tag, out: (f"from benchmarks.drp_against import _build_child; "  # noqa: E731
                              f"_build_child({tag.split('r')[0].replace('x', ', ')}, {out!r})")
    got = {}
    for tag, side, z in _against(rev, child, tags):
        got.setdefault((tag.split("r")[0], side), []).append(z)
    rows = []
    for K, B in sizes:
        old, new = got[f"{K}x{B}", "old"], got[f"{K}x{B}", "new"]
        for b in BUILDERS:
            o, n = min(float(z[f"ms_{b}"]) for z in old), min(float(z[f"ms_{b}"]) for z in new)
            rows.append({"builder": b, "K": K, "B": B, "against": rev, "rounds": rounds, "old_ms": round(o, 2),
                         "new_ms": round(n, 2), "speedup": o / n,
                         "identical_tours": all(np.array_equal(x[f"tours_{b}"], y[f"tours_{b}"])
                                                for x in old for y in new)})
    return rows


def figure_against(rev, graphs, nodes, alphas):
    """The figure-3.1 experiment with the ``jaxdc`` of ``rev`` and the working tree's (fresh processes)."""
    child = lambda _, out: (f"from benchmarks.drp_against import _fig_child; "  # noqa: E731
                            f"_fig_child({graphs}, {nodes}, {list(alphas)!r}, {out!r})")
    got = {side: z for _, side, z in _against(rev, child, ["figure"])}
    old, new = got["old"], got["new"]
    row = {"graphs": graphs, "nodes": nodes, "alphas": len(alphas), "against": rev}
    for run in ("first", "warm"):
        row[f"old_{run}_s"], row[f"new_{run}_s"] = float(old[f"{run}_s"]), float(new[f"{run}_s"])
        row[f"speedup_{run}"] = row[f"old_{run}_s"] / row[f"new_{run}_s"]
        row[f"{run}_parts_s"] = {k[len(run) + 3:]: [round(float(old[k]), 2), round(float(new[k]), 2)]
                                 for k in old if k.startswith(f"{run}_t_")}
    raws = sorted(k for k in old if k.startswith("raw_"))
    row["identical_rewards"] = bool(raws == sorted(k for k in new if k.startswith("raw_")) and
                                    all(np.array_equal(old[k], new[k]) for k in raws))
    # Float tolerance: a revision whose rewards are XLA float32 (rather than float64 from the tours) differs in
    # the last float32 bits even where every tour is the same.
    rel = [float(np.max(np.abs(old[k] - new[k]) / np.maximum(np.abs(old[k]), 1.0))) for k in raws if k in new]
    row["max_rel_reward_difference"] = max(rel, default=0.0)
    row["identical_plans"] = bool("plans" in old and "plans" in new and str(old["plans"]) == str(new["plans"]))
    row["rewards_within_float32_tolerance"] = bool(raws == sorted(k for k in new if k.startswith("raw_")) and
                                                   row["max_rel_reward_difference"] <= 1e-5)
    # per combination: instances whose reward differs, and the largest difference
    row["reward_differences"] = {k[4:]: [int((old[k] != new[k]).sum()), float(np.abs(old[k] - new[k]).max())]
                                 for k in raws if k in new and not np.array_equal(old[k], new[k])}
    return row
