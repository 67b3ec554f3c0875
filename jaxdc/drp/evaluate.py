"""``R(C)`` for batches of clusters (sections 3.4.1-3.4.2): tours built on the device, rewards on the host.

A cluster's reward is that of the tour a builder makes over all of it (the
thesis' ``BuildTour'``, Algorithm 5). Batches of clusters of any sizes are
compacted to their size bucket, built by one jitted, vmapped program per chunk
(:mod:`jaxdc.drp.batching`), and the reward of every tour (Eq. 3.1) is computed
from the tour alone in float64 NumPy (:func:`host_parts`), so it depends neither
on the compiled program nor on the batch the tour was built in.
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.drp.batching import bucket, bucketed
from jaxdc.drp.tours import build_order, gi_trajectory
from jaxdc.drp.world import tour_parts


class ClusterEvaluation(NamedTuple):
    """Tours and rewards of a batch of ``J`` clusters (numpy)."""

    rewards: np.ndarray  # [J] float64, Eq. 3.1 of each tour
    tours: np.ndarray  # [J, n] int32 graph indices, padded with -1
    collected: np.ndarray  # [J] float64, sum_v P_t(v) beta(v)
    p_return: np.ndarray  # [J] float64, P_t(0)


def members(masks, K):
    """``[J, K]`` graph indices of each cluster's members in index order, padded with the base (0)."""
    rows, cols = np.nonzero(masks)
    starts = np.concatenate([[0], np.cumsum(masks.sum(1))[:-1]])
    subs = np.zeros((masks.shape[0], K), np.int32)
    subs[rows, np.arange(len(rows)) - starts[rows]] = cols
    return subs


@partial(jax.jit, static_argnames=("criterion", "K"))
def _build(criterion, K, P, beta, gidx, alpha, subs, sizes, prefix=None, done=None):
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


def host_parts(D64, beta64, psi64, gidx, tours):
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


def host_arrays(D, beta, psi):
    """``(D, beta, psi)`` as float64 NumPy arrays for :func:`host_parts`."""
    return tuple(np.asarray(x, np.float64) for x in (D, beta, psi))


def combine(collected, p_return, alpha):
    """``R(C) = collected + P_t(0) alpha - alpha`` (Eq. 3.1 for one tour) from the alpha-free parts, in
    float64. An empty tour's parts are both 0, so this gives it ``-alpha``; no caller evaluates an empty
    cluster."""
    alpha = np.asarray(alpha, np.float64)
    return (np.asarray(collected, np.float64) + np.asarray(p_return, np.float64) * alpha) - alpha


def evaluate(criterion, D, beta, psi, gidx, alpha, masks, P=None, resume=None, host=None) -> ClusterEvaluation:
    """Tours and rewards of a batch of clusters of any sizes (bucketed by size, chunked, jitted).

    ``D [G, n+1, n+1]``, ``beta [G, n+1]``, ``psi [G]``; ``gidx``, ``alpha``: ``[J]``;
    ``masks``: ``[J, n+1]`` bool. ``resume = (prefix [J, n+1], done [J])``: GI only,
    continue each tour from a partial tour (see :func:`_build`). ``P``: ``psi**D``
    if already at hand; ``host``: :func:`host_arrays` of ``(D, beta, psi)`` if already at hand.
    """
    masks = np.asarray(masks, bool)
    J, n1 = masks.shape
    n = n1 - 1
    P = psi[:, None, None] ** D if P is None else P
    gidx = np.asarray(gidx, np.int32)
    alpha = np.asarray(alpha, np.float32)
    tours = np.full((J, n), -1, np.int32)
    sizes = masks.sum(1).astype(np.int32)
    subs = members(masks, n)

    pending = []

    def run(K, part, pad):
        extra = () if resume is None else (jnp.asarray(resume[0][pad]), jnp.asarray(resume[1][pad], jnp.int32))
        pending.append((K, part, _build(criterion, K, P, beta, jnp.asarray(gidx[pad]), jnp.asarray(alpha[pad]),
                                        jnp.asarray(subs[pad, :K]), jnp.asarray(sizes[pad]), *extra)))

    # Resumed jobs share a while_loop best when they have as many insertions left.
    bucketed(sizes, n, run, order=None if resume is None else sizes - np.asarray(resume[1]))
    for K, part, res in pending:  # read back after every call is dispatched: the host work overlaps the builds
        tours[part, :K] = np.asarray(res)[: len(part)]
    w = max(1, int(sizes.max(initial=1)))
    collected, p_return = host_parts(*(host or host_arrays(D, beta, psi)), gidx, tours[:, :w])
    return ClusterEvaluation(combine(collected, p_return, alpha), tours, collected, p_return)


def evaluate_clusters(criterion, D, beta, psi, gidx, alpha, masks, with_tours=False, resume=None, P=None,
                      host=None):
    """``R(C)`` for a batch of clusters of any sizes: :func:`evaluate`'s rewards ``[J]`` (float64, Eq. 3.1
    of each tour, computed on the host from the tour, :func:`host_parts`), and with ``with_tours`` also
    its tours ``[J, n]`` of graph indices."""
    res = evaluate(criterion, D, beta, psi, gidx, alpha, masks, P, resume, host)
    return (res.rewards, res.tours) if with_tours else res.rewards


def evaluate_parts(criterion, D, beta, psi, gidx, masks, P=None, host=None):
    """``(collected, p_return)`` of the append-builder tours of ``masks [J, n+1]`` (graph ``gidx``).

    The append criteria never look at ``beta(0) = alpha`` (node 0 is never a
    candidate and is masked out of every sum), so the tour is the same for
    every robot value; it is built with ``beta(0) = 0``.
    ``R(C) = collected + p_return * alpha - alpha`` (:func:`combine`).
    """
    res = evaluate(criterion, D, beta, psi, gidx, np.zeros(len(gidx), np.float32), masks, P, host=host)
    return res.collected, res.p_return


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
    kmax = bucket(sizes.max(), n1 - 1)
    cycles = np.zeros((J, kmax + 1, kmax + 1), np.int32)
    first = np.zeros((J, n1), np.int32)

    def run(K, part, pad):
        c, f = _trajectories(K, D, beta, psi, jnp.asarray(gidx[pad]), jnp.asarray(alpha[pad], jnp.float32),
                             jnp.asarray(masks[pad]))
        cycles[part, : K + 1, : K + 1] = np.asarray(c)[: len(part)]
        first[part] = np.asarray(f)[: len(part)]

    bucketed(sizes, n1 - 1, run, area=lambda K: K * n1)
    return cycles, first
