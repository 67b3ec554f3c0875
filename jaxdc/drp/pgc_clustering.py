"""PGC: the Progressive Gain-aware Clustering, Algorithms 3-4 (section 3.4.3).

A cluster's reward is estimated without building a tour, from a rooted k-MST:
the cluster keeps its entry node (the member nearest the base), the total
length of its MST, the estimated gain and the estimated cost of losing the
robot (:class:`PGCCluster`); merging two clusters (:func:`pgc_merge`,
Algorithm 3) joins their MSTs by the shortest edge between them and walks the
farther cluster's tree from that edge, shortest frontier edge first.

Everything here is plain Python and float64 NumPy; the MST adjacency lists of
all clusters live in one dict (the clusters are disjoint).
"""

from __future__ import annotations

import heapq
from typing import NamedTuple

import numpy as np


class PGCCluster(NamedTuple):
    """The data structure of a cluster ``C_i`` (section 3.4.3), without its MST adjacency list."""

    nodes: list  # C_i: the node indices, sorted
    entry: int  # e_i: the member nearest the base
    length: float  # l_i: the total edge length of the cluster's MST
    gain: float  # g_i: the estimated reward collected from the members
    cost: float  # c_i: the estimated loss of the robot, (1 - psi**(...)) alpha

    @property
    def value(self) -> float:
        """The estimated reward of the cluster, ``g_i - c_i``."""
        return self.gain - self.cost


class PGCMerge(NamedTuple):
    """Algorithm 3's estimate of ``C_i ∪ C_j`` before the merge is made."""

    near: PGCCluster  # the cluster whose entry is nearer the base (C_i after line 3's swap)
    far: PGCCluster  # the other one (C_j)
    entry: int  # e_ij
    length: float  # l_ij
    gain: float  # g_ij
    cost: float  # c_ij
    edge: tuple  # (v_i*, v_j*): the new MST edge

    def merged(self) -> PGCCluster:
        """The merged cluster's record (its node list is built only here)."""
        return PGCCluster(sorted(self.near.nodes + self.far.nodes), self.entry, self.length, self.gain, self.cost)


class PGCResult(NamedTuple):
    """Algorithm 4's output for one instance."""

    clusters: list  # the clusters' sorted node lists, in slot order (records[i].nodes)
    records: list  # their PGCCluster records, in the same order
    edges: list  # every MST edge (v_i*, v_j*) in the order the merges made them


def _merge_estimate(D, Dl, bl, psi, alpha, adj, ci: PGCCluster, cj: PGCCluster, ii, ij) -> PGCMerge:
    """Algorithm 3 on ``D`` (array, for the closest-pair block) and ``Dl``, ``bl`` (``D`` and ``beta``
    as Python lists: the BFS reads single entries, which are much faster from lists; the float64
    values and operations are the same). ``ii``, ``ij``: the nodes of ``ci``, ``cj`` as index arrays."""
    d0i, d0j = Dl[0][ci.entry], Dl[0][cj.entry]
    if d0i > d0j:  # lines 2-4
        ci, cj, d0i, d0j, ii, ij = cj, ci, d0j, d0i, ij, ii
    k = int(D[ii[:, None], ij].argmin())  # lines 6-12: first strict minimum
    vi, vj = ci.nodes[k // len(cj.nodes)], cj.nodes[k % len(cj.nodes)]
    length, gain = ci.length, ci.gain
    heap, seen = [(Dl[vi][vj], vj)], set()
    while heap:  # BFS over C_j's tree from v_j*, shortest frontier edge first (lines 17-23)
        d, v = heapq.heappop(heap)
        seen.add(v)
        length += d
        gain += psi ** (d0i + length) * bl[v]
        row = Dl[v]
        for u in adj[v]:
            if u not in seen:
                heapq.heappush(heap, (row[u], u))
    cost = (1.0 - psi ** (d0i + d0j + length)) * alpha  # line 24
    return PGCMerge(ci, cj, ci.entry, length, gain, cost, (vi, vj))


def pgc_merge(D, beta, psi, alpha, adj, ci: PGCCluster, cj: PGCCluster):
    """Algorithm 3 (PGCMerge): the k-MST estimate of ``C_i ∪ C_j``.

    ``adj`` holds the MST adjacency lists ``L`` of all clusters (they are
    disjoint, so one dict of lists serves all). Returns the merged
    :class:`PGCCluster` and the new MST edge ``(v_i*, v_j*)``; ``adj`` is not modified.
    """
    D = np.asarray(D, np.float64)
    est = _merge_estimate(D, D.tolist(), np.asarray(beta, np.float64).tolist(), float(psi), float(alpha), adj,
                          ci, cj, np.asarray(ci.nodes), np.asarray(cj.nodes))
    return est.merged(), est.edge


def _initial_gains(D, beta, psi, alpha, value):
    """Line 11's ``Delta`` of every pair of singletons ``i < j``, vectorised: ``[n+1, n+1]``, ``-inf`` elsewhere."""
    n = D.shape[0] - 1
    gain = np.full((n + 1, n + 1), -np.inf)
    d0 = D[0]
    i_idx, j_idx = np.triu_indices(n, 1)
    i_idx, j_idx = i_idx + 1, j_idx + 1
    swap = d0[i_idx] > d0[j_idx]
    ei = np.where(swap, j_idx, i_idx)
    ej = np.where(swap, i_idx, j_idx)
    length = D[i_idx, j_idx]
    g = psi ** d0[ei] * beta[ei] + psi ** (d0[ei] + length) * beta[ej]
    c = (1 - psi ** (d0[ei] + d0[ej] + length)) * alpha
    gain[i_idx, j_idx] = (g - c) - np.array([value[v] for v in i_idx]) - np.array([value[v] for v in j_idx])
    return gain


def pgc(D, beta, psi, alpha) -> PGCResult:
    """Algorithm 4 (PGC) for one instance. ``D [n+1, n+1]``, ``beta [n+1]`` (node rewards).

    Pair gains are kept in a dense matrix over slots (a cluster's slot is its
    smallest node; upper triangle), and the first pair with the largest gain
    merges while that gain is above 0. After a merge only the pairs with the
    new cluster are re-estimated. Returns a :class:`PGCResult`: the clusters'
    node lists and :class:`PGCCluster` records in slot order, and the MST edges.
    """
    D = np.asarray(D, np.float64)
    beta = np.asarray(beta, np.float64)
    psi, alpha = float(psi), float(alpha)
    Dl, bl = D.tolist(), beta.tolist()
    n = D.shape[0] - 1
    S = {v: PGCCluster([v], v, 0.0, psi ** D[0, v] * beta[v], (1 - psi ** (2 * D[0, v])) * alpha)
         for v in range(1, n + 1)}  # lines 1-5
    adj = {v: [] for v in range(1, n + 1)}
    value = {v: S[v].value for v in S}
    index = {v: np.asarray([v]) for v in S}  # each cluster's nodes as an index array, by slot

    def estimate(a, b):
        est = _merge_estimate(D, Dl, bl, psi, alpha, adj, S[a], S[b], index[a], index[b])
        return (est.gain - est.cost) - value[a] - value[b], est

    gain = _initial_gains(D, beta, psi, alpha, value)
    estimates = {}
    edges = []
    while True:
        k = int(gain.argmax())
        a, b = k // (n + 1), k % (n + 1)
        if not gain[a, b] > 0:
            break
        est = estimates.pop((a, b), None) or estimate(a, b)[1]
        merged = est.merged()
        u, v = est.edge
        adj[u].append(v)
        adj[v].append(u)
        edges.append(est.edge)
        del S[b]
        S[a] = merged
        value[a] = merged.value
        index[a] = np.asarray(merged.nodes)
        del index[b]
        gain[b, :] = -np.inf
        gain[:, b] = -np.inf
        estimates.clear()
        for o in S:
            if o == a:
                continue
            lo, hi = min(a, o), max(a, o)
            gain[lo, hi], estimates[(lo, hi)] = estimate(lo, hi)
    records = [S[s] for s in sorted(S)]
    return PGCResult([r.nodes for r in records], records, edges)
