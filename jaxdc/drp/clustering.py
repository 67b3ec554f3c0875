"""Clustering for the number of robots (section 3.4.1 and 3.4.3).

* :func:`nc` is the naive agglomerative clustering, Algorithm 1, with a tour
  builder as the cluster evaluator ``R`` (Algorithm 5): ``R(C)`` is the reward
  (Eq. 3.1) of the tour the builder makes over *all* of ``C`` (the thesis'
  "small modification", ``BuildTour'``). It runs many instances (graphs x
  robot values) in lockstep: the bookkeeping is vectorised NumPy, and the tour
  builds of one round, over all instances, go to one jitted, vmapped call per
  cluster-size bucket. After a merge only the pairs that involve the new
  cluster are re-evaluated; the initial all-pairs round is one batched call.
  For the append builders (whose tours do not depend on alpha) a tour is
  built once per (graph, node set) and shared by all robot values and rounds
  (:class:`_TourCache`); GI's tours depend on alpha and are not shared.
* :func:`pgc` is the Progressive Gain-aware Clustering, Algorithms 3-4, with
  its rooted k-MST estimate of a cluster's gain.
* :func:`plan_tours` is lines 3-5 of Algorithms 5 and 6: one tour per cluster.

Clusters are identified by their *slot*, the smallest node index in them; the
cluster list ``S`` of Algorithm 1 is kept in slot order, so "the first pair
``(i, j)`` with the largest gain" breaks ties. A merge needs a gain strictly
above 0 (Algorithm 1, line 11 with ``Delta* = 0``).
"""

from __future__ import annotations

import heapq
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.drp.tours import BUILDERS, build_tour, gi_trajectory
from jaxdc.drp.world import tour_gain

CLUSTERINGS = ("nc", "pgc")


def _bucket(size, n):
    """Padded cluster size: the next power of two, at most ``n``."""
    k = 1 << int(np.ceil(np.log2(max(int(size), 2))))
    return min(k, n)


def _chunk(area, count):
    """Batch width for ``count`` jobs whose arrays have ``area`` entries: a power of 4 from 64, memory-capped."""
    big = int(min(8192, max(64, 2 ** 21 // area)))
    width = 64
    while width < count and width < big:
        width *= 4
    return min(width, big)


def _bucketed(sizes, n, run, order=None, area=lambda K: K * K):
    """Call ``run(K, part, pad)`` for every size bucket ``K`` and chunk of jobs.

    Jobs are grouped by :func:`_bucket` of ``sizes``, sorted by ``order``
    (default: their size) so that jobs of similar loop length share a
    ``while_loop``, and cut into chunks of :func:`_chunk` width; ``pad`` is
    ``part`` padded to that width by repeating its first job, so each
    (bucket, width) compiles once.
    """
    sizes = np.asarray(sizes)
    order = sizes if order is None else np.asarray(order)
    buckets = np.array([_bucket(s, n) for s in range(n + 1)])[sizes]
    for K in np.unique(buckets):
        sel = np.flatnonzero(buckets == K)
        sel = sel[np.argsort(order[sel], kind="stable")]
        big = _chunk(area(int(K)), len(sel))
        for start in range(0, len(sel), big):
            part = sel[start:start + big]
            width = _chunk(area(int(K)), len(part))
            run(int(K), part, np.concatenate([part, np.full(width - len(part), part[0])]))


def _compact(D, beta, g, m, K):
    """Cluster ``m`` of graph ``g`` compacted to ``K`` slots (members in index order, base first):
    ``(sub, Ds, bs, ms)`` with ``sub`` the graph index of each slot."""
    idx = jnp.argsort(~m, stable=True)[:K]
    valid = jnp.arange(K) < m.sum()
    sub = jnp.concatenate([jnp.zeros((1,), idx.dtype), idx])
    Ds = D[g][sub[:, None], sub[None, :]]
    return sub, Ds, beta[g][sub], jnp.concatenate([jnp.zeros((1,), bool), valid])


@partial(jax.jit, static_argnames=("criterion", "K"))
def _evaluate(criterion, K, D, beta, psi, gidx, alpha, masks, prefix=None, done=None):
    """Tour rewards of the clusters ``masks [J, n+1]`` (graph ``gidx``, robot value ``alpha``).

    Each cluster is compacted to ``K`` slots (members in index order, so ties
    still go to the lowest node) before ``BuildTour`` runs on it. With
    ``prefix [J, n+1]`` (partial GI tours in graph indices, base first) and
    ``done [J]`` (their lengths), GI resumes from them instead of starting empty.
    """

    def one(g, a, m, pre, d):
        sub, Ds, bs, ms = _compact(D, beta, g, m, K)
        bs = bs.at[0].set(a)
        resume = None
        if pre is not None:
            rank = jnp.cumsum(m).astype(jnp.int32)  # slot of each member (m[0] is False)
            inpre = jnp.zeros(m.shape, bool).at[pre].set(True)
            ms = ms & ~inpre[sub]
            resume = (rank[pre[: K + 1]], d)
        tour, reward = build_tour(criterion, Ds, bs, psi[g], ms, resume)
        return reward, jnp.where(tour >= 0, sub[jnp.maximum(tour + 0, 0)], -1)

    return jax.vmap(one)(gidx, alpha, masks, prefix, done)


def evaluate_clusters(criterion, D, beta, psi, gidx, alpha, masks, with_tours=False, resume=None):
    """``R(C)`` for a batch of clusters of any sizes (bucketed by size, chunked, jitted).

    ``D [G, n+1, n+1]``, ``beta [G, n+1]``, ``psi [G]``; ``gidx``, ``alpha``: ``[J]``;
    ``masks``: ``[J, n+1]`` bool. ``resume = (prefix [J, n+1], done [J])``: GI only,
    continue each tour from a partial tour (see :func:`_evaluate`). Returns
    rewards ``[J]`` (and tours ``[J, n]`` of graph indices).
    """
    masks = np.asarray(masks, bool)
    J, n1 = masks.shape
    n = n1 - 1
    rewards = np.zeros(J, np.float32)
    tours = np.full((J, n), -1, np.int32) if with_tours else None
    sizes = masks.sum(1)

    def run(K, part, pad):
        extra = () if resume is None else (jnp.asarray(resume[0][pad]), jnp.asarray(resume[1][pad], jnp.int32))
        r, t = _evaluate(criterion, K, D, beta, psi, jnp.asarray(gidx[pad]), jnp.asarray(alpha[pad], jnp.float32),
                         jnp.asarray(masks[pad]), *extra)
        rewards[part] = np.asarray(r)[: len(part)]
        if with_tours:
            tours[part, :K] = np.asarray(t)[: len(part)]

    # Resumed jobs share a while_loop best when they have as many insertions left.
    _bucketed(sizes, n, run, order=None if resume is None else sizes - np.asarray(resume[1]))
    return (rewards, tours) if with_tours else rewards


@partial(jax.jit, static_argnames="K")
def _trajectories(K, D, beta, psi, gidx, alpha, masks):
    """:func:`jaxdc.drp.tours.gi_trajectory` of the clusters ``masks [J, n+1]`` (graph ``gidx``, ``alpha``)."""

    def one(g, a, m):
        return gi_trajectory(D[g], beta[g].at[0].set(a), psi[g], m, K)

    return jax.vmap(one)(gidx, alpha, masks)


def gi_trajectories(D, beta, psi, gidx, alpha, masks):
    """:func:`_trajectories` for a batch of any sizes: ``(cycles [J, Kmax+1, Kmax+1], first [J, n+1])``."""
    masks = np.asarray(masks, bool)
    J, n1 = masks.shape
    sizes = masks.sum(1)
    kmax = _bucket(sizes.max(), n1 - 1)
    cycles = np.zeros((J, kmax + 1, kmax + 1), np.int32)
    first = np.zeros((J, n1), np.int32)

    def run(K, part, pad):
        c, f = _trajectories(K, D, beta, psi, jnp.asarray(gidx[pad]), jnp.asarray(alpha[pad], jnp.float32),
                             jnp.asarray(masks[pad]))
        cycles[part, : K + 1, : K + 1] = np.asarray(c)[: len(part)]
        first[part] = np.asarray(f)[: len(part)]

    _bucketed(sizes, n1 - 1, run, area=lambda K: K * n1)
    return cycles, first


def _tour_parts(D, psi, tour):
    """``P_t(0)`` of a compacted tour: its return probability, computed as in :func:`tour_gain`."""
    valid = tour >= 0
    node = jnp.where(valid, tour, 0)
    prev = jnp.concatenate([jnp.zeros((1,), node.dtype), node[:-1]])
    reach = jnp.cumsum(jnp.where(valid, D[prev, node], 0.0))
    last = jnp.where(valid.any(), node[jnp.maximum(valid.sum() - 1, 0)], 0)
    return jnp.where(valid.any(), psi ** (reach[-1] + D[last, 0]), 0.0)


@partial(jax.jit, static_argnames=("criterion", "K"))
def _evaluate_parts(criterion, K, D, beta, psi, gidx, masks):
    """``(collected, p_return)`` of the append-builder tours of ``masks [J, n+1]`` (graph ``gidx``).

    The append criteria never look at ``beta(0) = alpha`` (node 0 is never a
    candidate and is masked out of every sum), so the tour is the same for
    every robot value; it is built with ``beta(0) = 0``, which makes the
    builder's reward exactly the collected part ``sum_v P_t(v) beta(v)``.
    ``R(C) = collected + p_return * alpha - alpha`` (:func:`_combine`).
    """

    def one(g, m):
        _, Ds, bs, ms = _compact(D, beta, g, m, K)
        bs = bs.at[0].set(0.0)
        tour, collected = build_tour(criterion, Ds, bs, psi[g], ms)
        return collected, _tour_parts(Ds, psi[g], tour)

    return jax.vmap(one)(gidx, masks)


def evaluate_parts(criterion, D, beta, psi, gidx, masks):
    """:func:`_evaluate_parts` for a batch of any sizes (bucketed, chunked like :func:`evaluate_clusters`)."""
    masks = np.asarray(masks, bool)
    J, n1 = masks.shape
    n = n1 - 1
    collected = np.zeros(J, np.float32)
    p_return = np.zeros(J, np.float32)

    def run(K, part, pad):
        c, p = _evaluate_parts(criterion, K, D, beta, psi, jnp.asarray(gidx[pad]), jnp.asarray(masks[pad]))
        collected[part] = np.asarray(c)[: len(part)]
        p_return[part] = np.asarray(p)[: len(part)]

    _bucketed(masks.sum(1), n, run)
    return collected, p_return


def _combine(collected, p_return, alpha):
    """``R(C)`` from the alpha-free parts, in float32 and in :func:`tour_reward`'s order of operations."""
    collected = np.asarray(collected, np.float32)
    alpha = np.asarray(alpha, np.float32)
    return (collected + np.asarray(p_return, np.float32) * alpha) - alpha


class _TourCache:
    """``(graph, node set) -> (collected, p_return)`` for the append builders, shared by all
    robot values of a graph and by all NC rounds: each node set's tour is built once."""

    def __init__(self, criterion, D, beta, psi):
        self.args = (criterion, D, beta, psi)
        self.index = {}
        self.collected = np.zeros(0, np.float32)
        self.p_return = np.zeros(0, np.float32)
        self.built = 0

    def rewards(self, gidx, masks, alpha):
        gidx = np.asarray(gidx, np.int32)
        masks = np.asarray(masks, bool)
        keys = np.concatenate([gidx.astype("<i4").view(np.uint8).reshape(-1, 4), np.packbits(masks, axis=1)], 1)
        keys = np.ascontiguousarray(keys).view(np.dtype((np.void, keys.shape[1])))[:, 0]
        uniq, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        slot = np.array([self.index.get(k.tobytes(), -1) for k in uniq], np.int64)
        new = np.flatnonzero(slot < 0)
        if len(new):
            rows = first[new]
            c, p = evaluate_parts(*self.args[:4], gidx[rows], masks[rows])
            base = len(self.collected)
            self.collected = np.concatenate([self.collected, c])
            self.p_return = np.concatenate([self.p_return, p])
            slot[new] = base + np.arange(len(new))
            for k, s in zip(uniq[new], slot[new]):
                self.index[k.tobytes()] = int(s)
            self.built += len(new)
        s = slot[inverse.reshape(-1)]
        return _combine(self.collected[s], self.p_return[s], alpha)


def nc(criterion, D, beta, psi, gidx, alpha, progress=None, cache=True, resume=False):
    """Algorithm 1 (NC) with ``BuildTour'_criterion`` as evaluator, for many instances at once.

    Args:
      criterion: a builder in :data:`jaxdc.drp.tours.BUILDERS`.
      D: ``[G, n+1, n+1]`` distances; beta: ``[G, n+1]`` rewards (``beta[:, 0]`` is
        replaced by each instance's ``alpha``); psi: ``[G]``.
      gidx, alpha: ``[I]`` the graph and robot value of each instance.
      progress: optional callable, called once per merge round.
      cache: for the append builders, build each (graph, node set)'s tour only
        once and share it across robot values and rounds (the tour does not
        depend on alpha; see :func:`_evaluate_parts`). Same result as
        ``cache=False``. GI's tours depend on alpha, so GI never caches.
      resume: for GI, after a merge run GI once over the new cluster ``C_a``
        (:func:`gi_trajectories`) and build each ``C_a ∪ C_k`` by resuming from
        the partial tour at the step where a node of ``C_k`` first cuts in:
        GI's scores depend on the partial tour only, so the steps before are
        the same (:func:`jaxdc.drp.tours.gi_trajectory`). Same clusters as
        ``resume=False`` (the default, which rebuilds every union from
        scratch); measured *slower* on 100-node graphs (docs/drp.md, Speed),
        since a node of ``C_k`` near the base cuts in at the first steps.

    Returns:
      ``member [I, n+1, n+1]`` bool: ``member[i, s]`` is the cluster in slot ``s``
      (all False for empty slots). Every node is in exactly one cluster.
    """
    if criterion not in BUILDERS:
        raise ValueError(f"builder must be one of {BUILDERS}, got {criterion!r}")
    D = jnp.asarray(D, jnp.float32)
    beta = jnp.asarray(beta, jnp.float32)
    psi = jnp.asarray(psi, jnp.float32)
    gidx = np.asarray(gidx, np.int32)
    alpha = np.asarray(alpha, np.float32)
    I, n1 = len(gidx), D.shape[1]
    eye = np.eye(n1, dtype=bool)
    eye[0, 0] = False
    member = np.broadcast_to(eye, (I, n1, n1)).copy()
    alive = np.ones((I, n1), bool)
    alive[:, 0] = False
    size = alive.astype(np.int32)

    # Singletons and the initial all-pairs round.
    inst = np.repeat(np.arange(I), n1 - 1)
    nodes = np.tile(np.arange(1, n1), I)
    R = np.zeros((I, n1), np.float32)
    a_idx, b_idx = np.triu_indices(n1 - 1, 1)
    a_idx, b_idx = a_idx + 1, b_idx + 1
    Rpair = np.full((I, n1, n1), -np.inf, np.float32)
    P = len(a_idx)
    tc = _TourCache(criterion, D, beta, psi) if cache and criterion != "gi" else None
    if tc is not None:
        # Singletons and pairs: one build per graph, shared by all its robot values.
        # (No later round asks for a set of size < 3, so they are not stored.)
        m = eye[a_idx] | eye[b_idx]
        for g in np.unique(gidx):
            its = np.flatnonzero(gidx == g)
            c1, p1 = evaluate_parts(criterion, D, beta, psi, np.full(n1 - 1, g, np.int32), eye[1:])
            c2, p2 = evaluate_parts(criterion, D, beta, psi, np.full(P, g, np.int32), m)
            for i in its:
                R[i, 1:] = _combine(c1, p1, alpha[i])
                Rpair[i, a_idx, b_idx] = _combine(c2, p2, alpha[i])
    else:
        R[inst, nodes] = evaluate_clusters(criterion, D, beta, psi, gidx[inst], alpha[inst], eye[nodes])
        for i in range(I):  # one instance's pairs at a time keeps the mask array small
            m = eye[a_idx] | eye[b_idx]
            Rpair[i, a_idx, b_idx] = evaluate_clusters(criterion, D, beta, psi, np.full(P, gidx[i]),
                                                       np.full(P, alpha[i]), m)
    upper = np.triu(np.ones((n1, n1), bool), 1)
    active = np.ones(I, bool)
    while True:
        gain = Rpair - R[:, :, None] - R[:, None, :]
        ok = upper[None] & alive[:, :, None] & alive[:, None, :]
        gain = np.where(ok, gain, -np.inf)
        flat = gain.reshape(I, -1)
        best = flat.argmax(1)
        active &= flat[np.arange(I), best] > 0
        if progress is not None:
            progress()
        if not active.any():
            return member
        act = np.flatnonzero(active)
        a, b = best[act] // n1, best[act] % n1
        member[act, a] |= member[act, b]
        member[act, b] = False
        alive[act, b] = False
        size[act, a] += size[act, b]
        size[act, b] = 0
        R[act, a] = Rpair[act, a, b]
        Rpair[act, b, :] = -np.inf
        Rpair[act, :, b] = -np.inf
        # Re-evaluate only the pairs (new cluster, k).
        other = alive[act].copy()
        other[np.arange(len(act)), a] = False
        rows, ks = np.nonzero(other)
        inst_j, a_j = act[rows], a[rows]
        masks = member[inst_j, a_j] | member[inst_j, ks]
        if tc is not None:
            r = tc.rewards(gidx[inst_j], masks, alpha[inst_j])
        elif criterion == "gi" and resume:
            cycles, first = gi_trajectories(D, beta, psi, gidx[act], alpha[act], member[act, a])
            done = np.where(member[inst_j, ks], first[rows], n1).min(1)
            done = np.minimum(done, size[inst_j, a_j])
            prefix = np.zeros((len(rows), n1), np.int32)
            prefix[:, : cycles.shape[2]] = cycles[rows, done]
            r = evaluate_clusters(criterion, D, beta, psi, gidx[inst_j], alpha[inst_j], masks,
                                  resume=(prefix, done))
        else:
            r = evaluate_clusters(criterion, D, beta, psi, gidx[inst_j], alpha[inst_j], masks)
        lo, hi = np.minimum(a_j, ks), np.maximum(a_j, ks)
        Rpair[inst_j, lo, hi] = r


# ----------------------------------------------------------------------------- PGC


class _PGCCluster:
    __slots__ = ("C", "e", "l", "g", "c")

    def __init__(self, C, e, l, g, c):
        self.C, self.e, self.l, self.g, self.c = C, e, l, g, c


def pgc_merge(D, beta, psi, alpha, adj, ci, cj):
    """Algorithm 3 (PGCMerge): the k-MST estimate of ``C_i ∪ C_j``.

    ``adj`` holds the MST adjacency lists ``L`` of all clusters (they are
    disjoint, so one dict of lists serves all). Returns the merged record and
    the new MST edge ``(v_i*, v_j*)``; ``adj`` is not modified.
    """
    if D[0, ci.e] > D[0, cj.e]:
        ci, cj = cj, ci
    block = D[np.ix_(ci.C, cj.C)]
    k = int(block.argmin())
    vi, vj = ci.C[k // len(cj.C)], cj.C[k % len(cj.C)]
    d0 = D[0, ci.e]
    l, g = ci.l, ci.g
    heap, seen = [(D[vi, vj], vj)], set()
    while heap:  # BFS over C_j's tree from v_j*, shortest frontier edge first (lines 17-23)
        d, v = heapq.heappop(heap)
        seen.add(v)
        l += d
        g += psi ** (d0 + l) * beta[v]
        for u in adj[v]:
            if u not in seen:
                heapq.heappush(heap, (D[u, v], u))
    c = (1.0 - psi ** (d0 + D[0, cj.e] + l)) * alpha
    return _PGCCluster(sorted(ci.C + cj.C), ci.e, l, g, c), (vi, vj)


def pgc(D, beta, psi, alpha):
    """Algorithm 4 (PGC) for one instance. ``D [n+1, n+1]``, ``beta [n+1]`` (node rewards).

    Returns ``(clusters, records)``: the list of clusters (sorted node lists, in
    slot order) and their records ``(e, l, g, c, edges)`` with the MST edges.
    """
    D = np.asarray(D, np.float64)
    beta = np.asarray(beta, np.float64)
    psi, alpha = float(psi), float(alpha)
    n = D.shape[0] - 1
    S = {}
    for v in range(1, n + 1):
        S[v] = _PGCCluster([v], v, 0.0, psi ** D[0, v] * beta[v], (1 - psi ** (2 * D[0, v])) * alpha)
    adj = {v: [] for v in range(1, n + 1)}
    value = {v: S[v].g - S[v].c for v in S}

    def evaluate(a, b):
        k, edge = pgc_merge(D, beta, psi, alpha, adj, S[a], S[b])
        return (k.g - k.c) - value[a] - value[b], k, edge

    # Pair gains: a dense matrix over slots (upper triangle), first max wins.
    gain = np.full((n + 1, n + 1), -np.inf)
    cache = {}
    # Initial round, vectorised: singletons i < j.
    d0 = D[0]
    i_idx, j_idx = np.triu_indices(n, 1)
    i_idx, j_idx = i_idx + 1, j_idx + 1
    swap = d0[i_idx] > d0[j_idx]
    ei = np.where(swap, j_idx, i_idx)
    ej = np.where(swap, i_idx, j_idx)
    l = D[i_idx, j_idx]
    g = psi ** d0[ei] * beta[ei] + psi ** (d0[ei] + l) * beta[ej]
    c = (1 - psi ** (d0[ei] + d0[ej] + l)) * alpha
    gain[i_idx, j_idx] = (g - c) - np.array([value[v] for v in i_idx]) - np.array([value[v] for v in j_idx])
    edges = []
    while True:
        k = int(gain.argmax())
        a, b = k // (n + 1), k % (n + 1)
        if not gain[a, b] > 0:
            break
        _, merged, edge = cache.pop((a, b), None) or evaluate(a, b)
        adj[edge[0]].append(edge[1])
        adj[edge[1]].append(edge[0])
        edges.append(edge)
        del S[b]
        S[a] = merged
        value[a] = merged.g - merged.c
        gain[b, :] = -np.inf
        gain[:, b] = -np.inf
        cache.clear()
        for o in S:
            if o == a:
                continue
            lo, hi = min(a, o), max(a, o)
            d, kk, ed = evaluate(lo, hi)
            gain[lo, hi] = d
            cache[(lo, hi)] = (d, kk, ed)
    slots = sorted(S)
    records = [(S[s].e, S[s].l, S[s].g, S[s].c) for s in slots]
    return [S[s].C for s in slots], records, edges


# ----------------------------------------------------------------------------- plans


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
