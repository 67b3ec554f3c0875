"""Plans for many DRP instances at once: clustering (NC or PGC) then one tour per cluster (Algorithms 5-6).

An *instance* is a graph at a robot value: ``gidx[i]`` indexes the stacked
graph arrays ``(D, beta, psi)`` of :func:`graph_arrays`, ``alphas[i]`` is the
robot value (section 3.5 sweeps alpha over each graph).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from jaxdc.drp import world
from jaxdc.drp.nc_clustering import nc
from jaxdc.drp.pgc_clustering import pgc
from jaxdc.drp.plans import clusters_from_member, plan_tours

#: The clusterings of section 3.4: NC (Algorithm 1 with a builder, Algorithm 5) and PGC (Algorithms 3-4, 6).
CLUSTERINGS = ("nc", "pgc")


#: Host bytes per ``(n+1)^2`` entry of one NC instance: the merge state (``member`` bool, ``R``/``Rpair``/``gain``
#: float64 with their temporaries) and a round's union masks, members and tours. Measured (tracemalloc peak,
#: tests/drp/test_solve_memory.py): 25-46 bytes at n = 50..400.
NC_BYTES_PER_ENTRY = 48
#: Bytes per tour-cache entry (append builders) besides its ``n/8``-byte key: the dict slot, the key's and the
#: index's objects and the float64 parts with their copy. Measured: about 125.
CACHE_BYTES_PER_SET = 180
#: Host bytes per ``(n+1)^2`` entry of one PGC instance (distances as Python lists, the pair gains and their
#: temporaries). Measured: 90-94 bytes at n = 100..400.
PGC_BYTES_PER_ENTRY = 100
#: Bytes per ``(n+1)^2`` entry of one graph's arrays: ``D`` and ``psi**D`` (float32, device, twice) and their
#: float64 host copies.
GRAPH_BYTES_PER_ENTRY = 40


def plan_bytes(builder: str, clustering: str, graphs: int, instances: int, nodes: int) -> int:
    """Estimated peak bytes of :func:`solve_instances` on ``instances`` instances of ``graphs`` graphs of
    ``nodes`` nodes (what the ``eval.drp`` memory checks use). Within a factor of about 2 of the measured
    peak (``tests/drp/test_solve_memory.py``); it grows as ``instances * n^2`` (NC's initial all-pairs
    round runs in chunks of :data:`jaxdc.drp.nc_clustering.PAIR_CHUNK_BYTES`, so no ``n^3`` term).

    NC with an append builder also keeps a tour cache: about ``n^2 / 2`` node sets per graph and robot
    value, shared where the robot values merge alike; the estimate counts ``min(robot values, 4)`` of them
    per graph (measured 1 to 3.1 at 1 to 16 values)."""
    from jaxdc.drp import nc_clustering

    n1 = nodes + 1
    total = GRAPH_BYTES_PER_ENTRY * graphs * n1 * n1
    if clustering == "pgc":
        return total + PGC_BYTES_PER_ENTRY * n1 * n1 + (NC_BYTES_PER_ENTRY // 4) * instances * n1
    total += NC_BYTES_PER_ENTRY * instances * n1 * n1
    pairs = nodes * (nodes - 1) // 2
    total += nc_clustering.PAIR_ENTRY_BYTES * min(pairs, nc_clustering._pair_rows(n1)) * n1
    if builder != "gi":
        per_graph = min(max(instances // max(graphs, 1), 1), 4)
        total += graphs * per_graph * (n1 * n1 // 2) * (CACHE_BYTES_PER_SET + n1 // 8 + 4)
    return total


def graph_arrays(graphs):
    """``(D [G, n+1, n+1], beta [G, n+1], psi [G])`` of graphs with the same number of nodes (float32)."""
    D = jnp.stack([world.distances(g.base, g.nodes) for g in graphs])
    beta = jnp.stack([world.node_values(g.rewards, g.alpha) for g in graphs])
    psi = jnp.asarray([g.psi for g in graphs], jnp.float32)
    return D, beta, psi


def pgc_clusters(D, beta, psi, gidx, alphas, progress=None):
    """PGC (Algorithm 4) of every instance: per instance the clusters' node lists in slot order.
    ``progress()``, if given, is called once per instance."""
    Dn, bn, pn = np.asarray(D, np.float64), np.asarray(beta, np.float64), np.asarray(psi, np.float64)
    out = []
    for g, a in zip(gidx, alphas):
        out.append(pgc(Dn[g], bn[g], pn[g], float(a)).clusters)
        if progress is not None:
            progress()
    return out


def solve_instances(builder, clustering, D, beta, psi, gidx, alphas, progress=None):
    """Plans for many instances (graph ``gidx[i]`` at robot value ``alphas[i]``): ``[(reward, tours)]``.

    ``clustering`` is one of :data:`CLUSTERINGS`; ``builder`` (a name in
    :data:`jaxdc.drp.tours.BUILDERS`) evaluates NC's clusters and builds every
    tour. ``progress`` is called once per NC merge round or PGC instance.
    """
    gidx = np.asarray(gidx)
    alphas = np.asarray(alphas, np.float32)
    if clustering == "nc":
        member = nc(builder, D, beta, psi, gidx, alphas, progress=progress)
        clusters = [clusters_from_member(m) for m in member]
    elif clustering == "pgc":
        clusters = pgc_clusters(D, beta, psi, gidx, alphas, progress)
    else:
        raise ValueError(f"clustering must be one of {CLUSTERINGS}, got {clustering!r}")
    return plan_tours(builder, D, beta, psi, gidx, alphas, clusters)
