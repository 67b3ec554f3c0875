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
