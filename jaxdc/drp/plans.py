"""Plans from clusters: one ``BuildTour`` tour per cluster (Algorithms 5-6, lines 3-5)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from jaxdc.drp.evaluate import evaluate_clusters


def clusters_from_member(member):
    """Slot-ordered list of clusters (sorted node lists) from one instance's ``member`` matrix."""
    return [list(np.flatnonzero(row)) for row in member if row.any()]


def plan_tours(criterion, D, beta, psi, gidx, alpha, clusters, drop_nonpositive=True):
    """Algorithms 5-6, lines 3-5: a ``BuildTour`` tour per cluster, for many instances.

    ``clusters`` is a list (per instance) of lists of node lists. A robot is
    sent on a tour only if its expected reward is positive (section 3.5:
    "the algorithms rarely send out any robot at all" at high robot values);
    set ``drop_nonpositive=False`` to keep every tour. Returns, per instance,
    ``(total_reward, tours)`` with tours as lists of node indices.
    """
    n1 = np.asarray(D).shape[1]
    rows, inst = [], []
    for i, cl in enumerate(clusters):
        for c in cl:
            m = np.zeros(n1, bool)
            m[c] = True
            rows.append(m)
            inst.append(i)
    inst = np.asarray(inst, np.int64)
    if not rows:
        return [(0.0, []) for _ in clusters]
    rewards, tours = evaluate_clusters(criterion, jnp.asarray(D, jnp.float32), jnp.asarray(beta, jnp.float32),
                                       jnp.asarray(psi, jnp.float32), np.asarray(gidx)[inst],
                                       np.asarray(alpha, np.float32)[inst], np.stack(rows), with_tours=True)
    out = [[0.0, []] for _ in clusters]
    for j, i in enumerate(inst):
        if drop_nonpositive and not rewards[j] > 0:
            continue
        out[i][0] += float(rewards[j])
        out[i][1].append([int(v) for v in tours[j] if v >= 0])
    return [tuple(o) for o in out]
