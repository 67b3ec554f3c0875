"""The section 3.5 experiment (Figs. 3.1-3.5): every builder with NC and PGC over generated graphs and robot values.

Each graph of ``nodes`` nodes is generated from its own seed and solved at
every robot value; the result is, per ``(clustering, builder)``, the
``[graphs, alphas]`` expected rewards (Eq. 3.1) of the plans, and the time of
each part.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

from jaxdc.drp import world
from jaxdc.drp.plans import plan_tours
from jaxdc.drp.solve import graph_arrays, pgc_clusters, solve_instances

#: The node-reward setting of each chapter-3 figure (section 3.5).
FIGURE_REWARDS = {"3.1": "4-6", "3.2": "4-6", "3.3": "4-6", "3.4": "1-9", "3.5": "5"}
#: The robot values of the figures: alpha = 0, 5, ..., 80.
DEFAULT_ALPHAS = tuple(range(0, 85, 5))


@dataclass(frozen=True)
class ExperimentConfig:
    """The settings of one section 3.5 experiment: what its results are stored with, and reused for."""

    rewards: str  #: the node-reward setting (:data:`FIGURE_REWARDS`)
    graphs: int
    nodes: int
    alphas: tuple  #: the robot values, sorted, 0 included
    base: str  #: "centre" or "corner"
    seed: int  #: graph ``i`` is generated from ``seed + i``

    def as_dict(self) -> dict:
        """The settings as stored with the results (a stored run is reused only if they match)."""
        return {"rewards": self.rewards, "graphs": self.graphs, "nodes": self.nodes, "alphas": list(self.alphas),
                "base": self.base, "seed": self.seed}

    @property
    def tag(self) -> str:
        """The part of the result files' names that tells experiments apart."""
        return f"r{self.rewards}_g{self.graphs}_n{self.nodes}_{self.base}_s{self.seed}"


def experiment_arrays(rewards, graphs, nodes, alphas, base, seed):
    """The section 3.5 instances: ``(D, beta, psi)`` of the generated graphs and ``(gidx, alpha)`` per instance."""
    gs = [world.generate(seed + i, n=nodes, rewards=rewards, base=base) for i in range(graphs)]
    D, beta, psi = graph_arrays(gs)
    return D, beta, psi, np.repeat(np.arange(graphs), len(alphas)), np.tile(np.asarray(alphas, np.float32), graphs)


def pgc_plans(builders, D, beta, psi, gidx, alphas, clusters, raw, timing):
    """Algorithm 6's tours on the PGC ``clusters`` with each builder: fills ``raw[("pgc", b)]``
    (``[graphs, alphas]`` rewards, instances graph-major) and ``timing[f"pgc_{b}"]``."""
    n_alpha = int(np.sum(gidx == gidx[0]))
    for b in builders:
        t0 = time.perf_counter()
        res = plan_tours(b, D, beta, psi, gidx, alphas, clusters)
        raw[("pgc", b)] = np.asarray([r for r, _ in res]).reshape(-1, n_alpha)
        timing[f"pgc_{b}"] = time.perf_counter() - t0


def progress_units(builders, clusterings, nodes, instances):
    """The progress bar's length: ``nodes + 1`` NC merge rounds per builder (an upper bound; the rest is
    added when NC stops) and one unit per PGC instance."""
    return len(builders) * ("nc" in clusterings) * (nodes + 1) + ("pgc" in clusterings) * instances


def run_experiment(rewards, graphs, nodes, alphas, base, seed, builders, clusterings, quiet=False, progress=None):
    """The section 3.5 experiment: per (clustering, builder, alpha) the expected reward of each graph.

    Returns ``(raw, timing)``: ``raw[(clustering, builder)]`` is ``[graphs, len(alphas)]``,
    ``timing`` the seconds of each part. The progress bar counts NC merge rounds
    (``nodes + 1`` per builder) and PGC instances; ``progress(k)``, if given, is called
    with those units instead of drawing a bar.
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

                def tick():  # `done` is this builder's: solve_instances below calls tick within the iteration
                    done[0] += 1  # noqa: B023
                    if done[0] <= nodes:  # noqa: B023
                        advance(1)

                res = solve_instances(b, "nc", D, beta, psi, gidx, al, progress=tick)
                advance(nodes + 1 - min(done[0], nodes))
                raw[("nc", b)] = np.asarray([r for r, _ in res]).reshape(graphs, len(alphas))
                timing[f"nc_{b}"] = time.perf_counter() - t0
    return raw, timing
