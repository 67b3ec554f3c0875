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

from jaxdc.drp.tours import BUILDERS, build_order, gi_trajectory
from jaxdc.drp.world import tour_parts

CLUSTERINGS = ("nc", "pgc")


def _bucket(size, n):
    """Padded cluster size: the next of 2, 4, 8, 16, 24, 32, 48, 64, 96, ... (``2**k`` and, from 24 on,
    ``1.5 * 2**k``); ``n`` if that is at least ``0.9 n``.

    A tour build costs about ``K**2`` per step (``K**3`` for the loss-based criteria), so
    the half-steps above 16 cut the padding where the work is; each bucket is one
    compiled program per builder (seconds of XLA time), so there are few of them.
    """
    size = max(int(size), 2)
    k = 1 << int(np.ceil(np.log2(size)))
    if k >= 32 and 3 * k // 4 >= size:
        k = 3 * k // 4
    return n if k >= 0.9 * n else min(k, n)


def _width(area):
    """The batch width of a size bucket whose arrays have ``area`` entries: ``2**19 / area`` jobs,
    rounded down to a power of two, 16 to 4096.

    Each width is one compiled program per (builder, bucket), and XLA takes seconds per
    program on a CPU, so there is one: wide for small clusters, whose calls cost mostly
    their fixed overhead, narrower for large ones, where a part-filled batch wastes work.
    The rewards do not depend on it (they are computed from the tours on the host).
    """
    return 1 << int(np.clip(np.log2(2 ** 19 / area), 4, 12))


def _bucketed(sizes, n, run, order=None, area=lambda K: (K + 1) ** 2):
    """Call ``run(K, part, pad)`` for every size bucket ``K`` and chunk of jobs.

    Jobs are grouped by :func:`_bucket` of ``sizes``, sorted by ``order``
    (default: their size) so that jobs of similar loop length share a
    ``while_loop``, and cut into chunks of the width of :func:`_width`; ``pad``
    is ``part`` padded to its width by repeating its first job.
    """
    sizes = np.asarray(sizes)
    order = sizes if order is None else np.asarray(order)
    buckets = np.array([_bucket(s, n) for s in range(n + 1)])[sizes]
    for K in np.unique(buckets):
        sel = np.flatnonzero(buckets == K)
        sel = sel[np.argsort(order[sel], kind="stable")]
        width = _width(area(int(K)))
        for start in range(0, len(sel), width):
            part = sel[start:start + width]
            run(int(K), part, np.concatenate([part, np.full(width - len(part), part[0])]))


def _members(masks, K):
    """``[J, K]`` graph indices of each cluster's members in index order, padded with the base (0)."""
    rows, cols = np.nonzero(masks)
    starts = np.concatenate([[0], np.cumsum(masks.sum(1))[:-1]])
    subs = np.zeros((masks.shape[0], K), np.int32)
    subs[rows, np.arange(len(rows)) - starts[rows]] = cols
    return subs


@partial(jax.jit, static_argnames=("criterion", "K"))
def _evaluate(criterion, K, P, beta, gidx, alpha, subs, sizes, prefix=None, done=None):
    """Tours of the clusters ``subs [J, K]`` (members, ``sizes [J]`` of them) of graph ``gidx`` at
    robot value ``alpha``, in graph indices ``[J, K]`` padded with ``-1``.

    Each cluster is compacted to ``K`` slots (members in index order, so ties
    still go to the lowest node; ``P = psi**D`` is gathered straight from the
    ``[G, n+1, n+1]`` array, one ``[K+1, K+1]`` block per job) before
    ``BuildTour`` runs on it. With ``prefix [J, n+1]`` (partial GI tours in graph
    indices, base first) and ``done [J]`` (their lengths), GI resumes from them
    instead of starting empty.
    """

    def one(g, a, sub, size, pre, d):
        sub = jnp.concatenate([jnp.zeros((1,), sub.dtype), sub])
        ms = jnp.concatenate([jnp.zeros((1,), bool), jnp.arange(K) < size])
        Ps = P[g, sub[:, None], sub[None, :]]
        bs = beta[g, sub].at[0].set(a)
        resume = None
        if pre is not None:
            n1 = P.shape[1]
            slots = jnp.arange(1, K + 1, dtype=jnp.int32)
            rank = jnp.zeros((n1,), jnp.int32).at[sub[1:]].set(jnp.where(slots <= size, slots, 0))
            inpre = jnp.zeros((n1,), bool).at[pre].set(True)
            ms = ms & ~inpre[sub]
            resume = (rank[pre[: K + 1]], d)
        tour = build_order(criterion, Ps, bs, ms, resume)
        return jnp.where(tour >= 0, sub[jnp.maximum(tour, 0)], -1)

    return jax.vmap(one)(gidx, alpha, subs, sizes, prefix, done)


def _host_parts(D64, beta64, psi64, gidx, tours):
    """``(collected, p_return)`` of tours ``[J, L]`` (graph indices) of graphs ``gidx``, in float64 on
    the host (:func:`jaxdc.drp.world.tour_parts`).

    Every reward NC and the plans use comes from here, computed from the tour alone: a
    fixed NumPy program, so a cluster's reward does not depend on the compiled tour
    program or on the batch it was built in (XLA's float32 results do).
    """
    g = np.asarray(gidx)

    def dist(a, b):
        return D64[g.reshape(g.shape + (1,) * (a.ndim - 1)), a, b]

    return tour_parts(dist, lambda v: beta64[g[:, None], v], psi64[g], np.asarray(tours), xp=np)


def _host_arrays(D, beta, psi):
    """``(D, beta, psi)`` as float64 NumPy arrays for :func:`_host_parts`."""
    return tuple(np.asarray(x, np.float64) for x in (D, beta, psi))


def _run_evaluate(criterion, D, beta, psi, gidx, alpha, masks, P=None, resume=None, host=None):
    """:func:`_evaluate` for a batch of any sizes (bucketed by size, chunked): numpy
    ``(reward [J], tours [J, n], collected [J], p_return [J])``, the rewards in float64.
    ``host``: :func:`_host_arrays` of ``(D, beta, psi)`` if already at hand."""
    masks = np.asarray(masks, bool)
    J, n1 = masks.shape
    n = n1 - 1
    P = psi[:, None, None] ** D if P is None else P
    gidx = np.asarray(gidx, np.int32)
    alpha = np.asarray(alpha, np.float32)
    tours = np.full((J, n), -1, np.int32)
    sizes = masks.sum(1).astype(np.int32)
    subs = _members(masks, n)

    pending = []

    def run(K, part, pad):
        extra = () if resume is None else (jnp.asarray(resume[0][pad]), jnp.asarray(resume[1][pad], jnp.int32))
        pending.append((K, part, _evaluate(criterion, K, P, beta, jnp.asarray(gidx[pad]), jnp.asarray(alpha[pad]),
                                           jnp.asarray(subs[pad, :K]), jnp.asarray(sizes[pad]), *extra)))

    # Resumed jobs share a while_loop best when they have as many insertions left.
    _bucketed(sizes, n, run, order=None if resume is None else sizes - np.asarray(resume[1]))
    for K, part, res in pending:  # read back after every call is dispatched: the host work overlaps the builds
        tours[part, :K] = np.asarray(res)[: len(part)]
    width = max(1, int(sizes.max(initial=1)))
    collected, p_return = _host_parts(*(host or _host_arrays(D, beta, psi)), gidx, tours[:, :width])
    return _combine(collected, p_return, alpha), tours, collected, p_return


def evaluate_clusters(criterion, D, beta, psi, gidx, alpha, masks, with_tours=False, resume=None, P=None,
                      host=None):
    """``R(C)`` for a batch of clusters of any sizes (bucketed by size, chunked, jitted).

    ``D [G, n+1, n+1]``, ``beta [G, n+1]``, ``psi [G]``; ``gidx``, ``alpha``: ``[J]``;
    ``masks``: ``[J, n+1]`` bool. ``resume = (prefix [J, n+1], done [J])``: GI only,
    continue each tour from a partial tour (see :func:`_evaluate`). ``P``: ``psi**D``
    if already at hand (``host``: :func:`_host_arrays`). Returns rewards ``[J]``, float64 (Eq. 3.1 of each
    tour, computed on the host from the tour, :func:`_host_parts`), and tours ``[J, n]`` of graph indices.
    """
    rewards, tours, _, _ = _run_evaluate(criterion, D, beta, psi, gidx, alpha, masks, P, resume, host)
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


def evaluate_parts(criterion, D, beta, psi, gidx, masks, P=None, host=None):
    """``(collected, p_return)`` of the append-builder tours of ``masks [J, n+1]`` (graph ``gidx``).

    The append criteria never look at ``beta(0) = alpha`` (node 0 is never a
    candidate and is masked out of every sum), so the tour is the same for
    every robot value; it is built with ``beta(0) = 0``.
    ``R(C) = collected + p_return * alpha - alpha`` (:func:`_combine`).
    """
    _, _, collected, p_return = _run_evaluate(criterion, D, beta, psi, gidx, np.zeros(len(gidx), np.float32), masks,
                                              P, host=host)
    return collected, p_return


def _combine(collected, p_return, alpha):
    """``R(C) = collected + P_t(0) alpha - alpha`` (Eq. 3.1 for one tour) from the alpha-free parts, in
    float64 (0 for an empty tour: both parts are 0)."""
    alpha = np.asarray(alpha, np.float64)
    return (np.asarray(collected, np.float64) + np.asarray(p_return, np.float64) * alpha) - alpha


class _TourCache:
    """``(graph, node set) -> (collected, p_return)`` for the append builders, shared by all
    robot values of a graph and by all NC rounds: each node set's tour is built once."""

    def __init__(self, criterion, D, beta, psi, P, host):
        self.args = (criterion, D, beta, psi, P, host)
        self.index = {}
        self.collected = np.zeros(0, np.float64)
        self.p_return = np.zeros(0, np.float64)
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
            c, p = evaluate_parts(*self.args[:4], gidx[rows], masks[rows], *self.args[4:])
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
        depend on alpha; see :func:`evaluate_parts`). Same result as
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
    P = psi[:, None, None] ** D
    host = _host_arrays(D, beta, psi)
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
    R = np.zeros((I, n1), np.float64)
    a_idx, b_idx = np.triu_indices(n1 - 1, 1)
    a_idx, b_idx = a_idx + 1, b_idx + 1
    Rpair = np.full((I, n1, n1), -np.inf, np.float64)
    npair = len(a_idx)
    tc = _TourCache(criterion, D, beta, psi, P, host) if cache and criterion != "gi" else None
    if tc is not None:
        # Singletons and pairs: one build per graph, shared by all its robot values.
        # (No later round asks for a set of size < 3, so they are not stored.)
        m = eye[a_idx] | eye[b_idx]
        for g in np.unique(gidx):
            its = np.flatnonzero(gidx == g)
            c1, p1 = evaluate_parts(criterion, D, beta, psi, np.full(n1 - 1, g, np.int32), eye[1:], P, host)
            c2, p2 = evaluate_parts(criterion, D, beta, psi, np.full(npair, g, np.int32), m, P, host)
            for i in its:
                R[i, 1:] = _combine(c1, p1, alpha[i])
                Rpair[i, a_idx, b_idx] = _combine(c2, p2, alpha[i])
    else:
        R[inst, nodes] = evaluate_clusters(criterion, D, beta, psi, gidx[inst], alpha[inst], eye[nodes], P=P, host=host)
        for i in range(I):  # one instance's pairs at a time keeps the mask array small
            m = eye[a_idx] | eye[b_idx]
            Rpair[i, a_idx, b_idx] = evaluate_clusters(criterion, D, beta, psi, np.full(npair, gidx[i]),
                                                       np.full(npair, alpha[i]), m, P=P, host=host)
    # gain[i, s, t] = R(C_s ∪ C_t) - R(C_s) - R(C_t) for live slots s < t, -inf elsewhere; kept up to
    # date for the re-evaluated pairs only (the others' terms do not change), with the same float64 ops.
    gain = (Rpair - R[:, :, None]) - R[:, None, :]
    active = np.ones(I, bool)
    while True:
        act = np.flatnonzero(active)
        flat = gain[act].reshape(len(act), -1)
        best = flat.argmax(1)
        merge = flat[np.arange(len(act)), best] > 0
        active[act[~merge]] = False
        if progress is not None:
            progress()
        if not merge.any():
            return member
        act, best = act[merge], best[merge]
        a, b = best // n1, best % n1
        member[act, a] |= member[act, b]
        member[act, b] = False
        alive[act, b] = False
        size[act, a] += size[act, b]
        size[act, b] = 0
        R[act, a] = Rpair[act, a, b]
        Rpair[act, b, :] = -np.inf
        Rpair[act, :, b] = -np.inf
        gain[act, b, :] = -np.inf
        gain[act, :, b] = -np.inf
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
                                  resume=(prefix, done), P=P, host=host)
        else:
            r = evaluate_clusters(criterion, D, beta, psi, gidx[inst_j], alpha[inst_j], masks, P=P, host=host)
        lo, hi = np.minimum(a_j, ks), np.maximum(a_j, ks)
        Rpair[inst_j, lo, hi] = r
        gain[inst_j, lo, hi] = (r - R[inst_j, lo]) - R[inst_j, hi]


# ----------------------------------------------------------------------------- PGC


class _PGCCluster:
    __slots__ = ("C", "idx", "e", "l", "g", "c")

    def __init__(self, C, e, l, g, c):
        self.C, self.e, self.l, self.g, self.c = C, e, l, g, c
        self.idx = np.asarray(C)


def _pgc_merge(D, Dl, bl, psi, alpha, adj, ci, cj):
    """Algorithm 3 on ``D`` (array, for the closest-pair block) and ``Dl``, ``bl`` (``D`` and ``beta``
    as Python lists: the BFS reads single entries, which are much faster from lists; the float64
    values and operations are the same). Returns ``((ci, cj), e, l, g, c, edge)`` with ``ci`` the
    cluster whose entry is nearer the base; the merged node list is built only if the merge is made."""
    d0i, d0j = Dl[0][ci.e], Dl[0][cj.e]
    if d0i > d0j:
        ci, cj, d0i, d0j = cj, ci, d0j, d0i
    k = int(D[ci.idx[:, None], cj.idx].argmin())  # first strict minimum over sorted C_i x sorted C_j
    vi, vj = ci.C[k // len(cj.C)], cj.C[k % len(cj.C)]
    l, g = ci.l, ci.g
    heap, seen = [(Dl[vi][vj], vj)], set()
    while heap:  # BFS over C_j's tree from v_j*, shortest frontier edge first (lines 17-23)
        d, v = heapq.heappop(heap)
        seen.add(v)
        l += d
        g += psi ** (d0i + l) * bl[v]
        row = Dl[v]
        for u in adj[v]:
            if u not in seen:
                heapq.heappush(heap, (row[u], u))
    c = (1.0 - psi ** (d0i + d0j + l)) * alpha
    return (ci, cj), ci.e, l, g, c, (vi, vj)


def pgc_merge(D, beta, psi, alpha, adj, ci, cj):
    """Algorithm 3 (PGCMerge): the k-MST estimate of ``C_i ∪ C_j``.

    ``adj`` holds the MST adjacency lists ``L`` of all clusters (they are
    disjoint, so one dict of lists serves all). Returns the merged record and
    the new MST edge ``(v_i*, v_j*)``; ``adj`` is not modified.
    """
    D = np.asarray(D, np.float64)
    (ci, cj), e, l, g, c, edge = _pgc_merge(D, D.tolist(), np.asarray(beta, np.float64).tolist(), float(psi),
                                            float(alpha), adj, ci, cj)
    return _PGCCluster(sorted(ci.C + cj.C), e, l, g, c), edge


def pgc(D, beta, psi, alpha):
    """Algorithm 4 (PGC) for one instance. ``D [n+1, n+1]``, ``beta [n+1]`` (node rewards).

    Returns ``(clusters, records)``: the list of clusters (sorted node lists, in
    slot order) and their records ``(e, l, g, c, edges)`` with the MST edges.
    """
    D = np.asarray(D, np.float64)
    beta = np.asarray(beta, np.float64)
    psi, alpha = float(psi), float(alpha)
    Dl, bl = D.tolist(), beta.tolist()
    n = D.shape[0] - 1
    S = {}
    for v in range(1, n + 1):
        S[v] = _PGCCluster([v], v, 0.0, psi ** D[0, v] * beta[v], (1 - psi ** (2 * D[0, v])) * alpha)
    adj = {v: [] for v in range(1, n + 1)}
    value = {v: S[v].g - S[v].c for v in S}

    def evaluate(a, b):
        parts, e, l, g, c, edge = _pgc_merge(D, Dl, bl, psi, alpha, adj, S[a], S[b])
        return (g - c) - value[a] - value[b], (parts, e, l, g, c), edge

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
        _, ((ci, cj), e, l, g, c), edge = cache.pop((a, b), None) or evaluate(a, b)
        merged = _PGCCluster(sorted(ci.C + cj.C), e, l, g, c)
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
