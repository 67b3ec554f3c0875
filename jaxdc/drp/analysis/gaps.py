"""Optimality gaps: every (clustering, builder) against the exact solver on small graphs (section 3.5)."""

from __future__ import annotations

import sys

import numpy as np

from jaxdc.drp import world
from jaxdc.drp.exact import subset_dp
from jaxdc.drp.solve import CLUSTERINGS, graph_arrays, solve_instances
from jaxdc.drp.tours import BUILDERS


def gap_graphs(graphs, nodes, size, alphas, base, seed):
    """``graphs`` graphs of ``nodes`` nodes (rewards 4..6) in a ``size`` square, graph ``i`` from seed
    ``seed + i``, each at a robot value drawn from ``alphas`` (NumPy generator seeded with ``seed``)."""
    rng = np.random.default_rng(seed)
    return [world.generate(seed + i, n=nodes, rewards="4-6", base=base, size=size, alpha=float(rng.choice(alphas)))
            for i in range(graphs)]


def optimality_gaps(graphs, quiet=False):
    """Each heuristic's reward over the optimum (:func:`jaxdc.drp.exact.subset_dp.solve`) on ``graphs``.

    Returns one row per (clustering, builder): the mean and worst ratio, the share of graphs solved
    optimally (ratio above ``1 - 1e-4``) and the number of graphs compared (those with an optimum above 0).
    When no graph has an optimum above 0, the ratios are ``None`` and ``undefined`` says why.
    """
    from tqdm import tqdm

    D, beta, psi = graph_arrays(graphs)
    opt = np.asarray([subset_dp.solve(np.asarray(D[i]), np.asarray(beta[i]), 0.99)[0]
                      for i in tqdm(range(len(graphs)), desc="exact", file=sys.stderr, disable=quiet)])
    gidx = np.arange(len(graphs))
    al = np.asarray([g.alpha for g in graphs])
    rows = []
    for c in CLUSTERINGS:
        for b in BUILDERS:
            got = np.asarray([r for r, _ in solve_instances(b, c, D, beta, psi, gidx, al)])
            ok = opt > 1e-9
            if not ok.any():
                rows.append({"clustering": c, "builder": b, "mean_ratio": None, "min_ratio": None,
                             "optimal_share": None, "graphs": 0,
                             "undefined": "no graph has an optimal expected reward above 0"})
                continue
            ratio = got[ok] / opt[ok]
            rows.append({"clustering": c, "builder": b, "mean_ratio": float(ratio.mean()),
                         "min_ratio": float(ratio.min()), "optimal_share": float(np.mean(ratio > 1 - 1e-4)),
                         "graphs": int(ok.sum())})
    return rows
