"""The six tour builders of section 3.4.2 (Algorithm 2, Eqs. 3.2-3.8) as array programs.

Every builder takes ``(D, beta, psi, mask)`` for one cluster:

* ``D``: ``[K+1, K+1]`` distances with the base as index 0;
* ``beta``: ``[K+1]`` rewards with ``beta[0] = alpha``;
* ``mask``: ``[K+1]`` bool, the nodes of the cluster (``mask[0]`` is ignored).

It visits *all* nodes of the cluster and returns ``(tour, reward)``: the
tour as ``[K]`` indices into ``D`` in visiting order, padded with ``-1``,
and its reward (Eq. 3.1 for one tour; 0 for an empty cluster). The loop over
insertions is a ``lax.while_loop``; each step scores every candidate (and,
for GI, every insertion position) at once. Builders are pure functions of
arrays, so they ``jit`` and ``vmap`` over graphs or clusters.

The append builders NG, OSA, TL, GML and LPG score with the shared
:func:`jaxdc.core.tour_criteria.append_scores` (Eqs. 3.2-3.7) using
``p_next = psi**D[end]``, ``p_pair = psi**D`` and ``p_end = P_t(end)``.
GI (Eq. 3.8) inserts anywhere in the cyclic partial tour (with
``beta(0) = alpha``) and is DRP-only. Ties go to the lowest node index
(and, for GI, then to the earliest position).
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp

from jaxdc.core.tour_criteria import APPEND_CRITERIA, append_scores
from jaxdc.drp.world import tour_reward

#: Builders in the thesis' order (Table 3.1).
BUILDERS = APPEND_CRITERIA + ("gi",)


def _append_tour(criterion, D, beta, psi, mask):
    """Algorithm 2 with an append criterion: always insert at position ``|t|``."""
    n = D.shape[0] - 1
    P = psi ** D
    mask = jnp.asarray(mask, bool).at[0].set(False)

    def cond(st):
        mask, _, _, _, s = st
        return (s < n) & mask.any()

    def body(st):
        mask, end, p_end, tour, s = st
        scores = append_scores(criterion, P[end], P, beta, mask, p_end)
        u = jnp.argmax(scores)
        return mask.at[u].set(False), u, p_end * P[end, u], tour.at[s].set(u), s + 1

    init = (mask, jnp.int32(0), jnp.float32(1.0), jnp.full((n,), -1, jnp.int32), jnp.int32(0))
    _, _, _, tour, _ = jax.lax.while_loop(cond, body, init)
    return tour


def gi_scores(P, beta, cycle, m, mask, rows=None):
    """Eq. 3.8 for every unassigned ``u`` and every position ``i`` of the cyclic partial tour.

    ``P = psi**D``; ``cycle[0] = 0`` is the base and ``cycle[1..m]`` the partial
    tour. Inserting ``u`` after position ``i`` (between ``a = cycle[i]`` and its
    successor ``b``, the base after the last node) gains
    ``P_t(a) P(a, u) beta(u)`` and discounts everything after ``a``, the
    return's ``alpha`` included, by ``P(a, u) P(u, b) / P(a, b)``. Returns
    ``[positions, nodes]`` scores, ``-inf`` where invalid. ``rows`` is
    ``P[cycle]``, which :func:`_gi_tour` keeps up to date instead of gathering it.
    """
    k = jnp.arange(cycle.shape[0])
    inside = k <= m
    nxt = jnp.where(k < m, jnp.roll(cycle, -1), 0)
    p_au = P[cycle] if rows is None else rows
    p_ub = jnp.where((k < m)[:, None], jnp.roll(p_au, -1, axis=0), P[0][None, :])  # P[nxt]
    edge = jnp.where(inside, jnp.take_along_axis(p_au, nxt[:, None], axis=1)[:, 0], 1.0)
    reach = jnp.cumprod(jnp.concatenate([jnp.ones((1,), edge.dtype), edge[:-1]]))  # P_t(cycle[k])
    collected = jnp.where((k >= 1) & inside, reach * beta[cycle], 0.0)
    home = jnp.prod(edge) * beta[0]
    after = collected.sum() - jnp.cumsum(collected) + home  # value of everything after position i
    # D is symmetric, so rows serve for both ends: P[a, u] and P[u, b] = P[b, u].
    p_ab = jnp.maximum(edge, jnp.finfo(jnp.float32).tiny)[:, None]
    score = reach[:, None] * p_au * beta[None, :] - (1.0 - p_au * p_ub / p_ab) * after[:, None]
    return jnp.where(inside[:, None] & mask[None, :], score, -jnp.inf)


def _gi_insert(cycle, rows, P, u, i, k):
    """Insert node ``u`` after position ``i`` of ``cycle``; keep ``rows = P[cycle]`` in step."""
    cycle = jnp.where(k <= i, cycle, jnp.where(k == i + 1, u, jnp.roll(cycle, 1)))
    rows = jnp.where((k <= i)[:, None], rows, jnp.where((k == i + 1)[:, None], P[u][None, :],
                                                        jnp.roll(rows, 1, axis=0)))
    return cycle.astype(jnp.int32), rows


def _gi_tour(D, beta, psi, mask, cycle0=None, m0=0):
    """Greedy Insertion (GI, Eq. 3.8): the best node at the best position, cyclic tour.

    ``cycle0`` (``[K+1]``, base at 0, zeros after position ``m0``) resumes GI from a
    partial tour of ``m0`` nodes, as if its first ``m0`` insertions had been made
    here; ``mask`` then holds only the nodes still to insert. GI's score of a
    (position, node) pair depends on the partial tour only, not on the other
    unassigned nodes, so a run over ``C`` agrees with a run over a subset of ``C``
    until the first insertion of a node outside it (used by
    :func:`jaxdc.drp.clustering.nc` via :func:`gi_trajectory`).
    """
    n = D.shape[0] - 1
    mask = jnp.asarray(mask, bool).at[0].set(False)
    k = jnp.arange(n + 1)
    P = psi ** D
    cycle0 = jnp.zeros((n + 1,), jnp.int32) if cycle0 is None else jnp.asarray(cycle0, jnp.int32)

    def cond(st):
        mask, _, _, m = st
        return (m < n) & mask.any()

    def body(st):
        mask, cycle, rows, m = st
        score = gi_scores(P, beta, cycle, m, mask, rows)
        best = jnp.argmax(score.T)  # lowest node first, then earliest position
        u, i = best // (n + 1), best % (n + 1)
        cycle, rows = _gi_insert(cycle, rows, P, u, i, k)
        return mask.at[u].set(False), cycle, rows, m + 1

    init = (mask, cycle0, P[cycle0], jnp.asarray(m0, jnp.int32))
    _, cycle, _, m = jax.lax.while_loop(cond, body, init)
    return jnp.where(k[1:] <= m, cycle[1:], -1)


def gi_trajectory(D, beta, psi, mask, K):
    """GI (Eq. 3.8) over the cluster ``mask`` of the full graph, recording where other nodes would cut in.

    ``D [n+1, n+1]``, ``beta [n+1]`` (``beta[0] = alpha``), ``mask [n+1]`` with at
    most ``K`` nodes. Returns ``(cycles, first)``: ``cycles [K+1, K+1]``, the
    partial cyclic tour (graph indices, base first, zero-padded) before each
    step ``m``; ``first [n+1]``, for every node ``v`` outside the cluster the
    first step at which GI over ``cluster + {v, ...}`` would insert ``v`` rather
    than the cluster's own choice (higher score, or an equal score and a lower
    index: the tie rule of :func:`_gi_tour`), and ``|cluster|`` if never. GI over
    ``cluster ∪ C'`` therefore equals :func:`_gi_tour` resumed from
    ``cycles[d]`` with ``d = min(first[C'])``.
    """
    n1 = D.shape[0]
    mask = jnp.asarray(mask, bool).at[0].set(False)
    size = mask.sum().astype(jnp.int32)
    nodes = jnp.arange(n1)
    outside = ~mask & (nodes > 0)
    k = jnp.arange(K + 1)
    P = psi ** D

    def cond(st):
        return st[-1] < size

    def body(st):
        mask, cycle, rows, cycles, first, m = st
        cycles = cycles.at[m].set(cycle)
        score = gi_scores(P, beta, cycle, m, jnp.ones((n1,), bool), rows)  # every node, inside positions
        own = jnp.where(mask[None, :], score, -jnp.inf)
        best = jnp.argmax(own.T)
        u, i = best // (K + 1), best % (K + 1)
        s = own[i, u]
        bv = score.max(axis=0)
        cuts = outside & ((bv > s) | ((bv == s) & (nodes < u)))
        first = jnp.where(cuts & (first > m), m, first)
        cycle, rows = _gi_insert(cycle, rows, P, u, i, k)
        return mask.at[u].set(False), cycle, rows, cycles, first, m + 1

    cycle0 = jnp.zeros((K + 1,), jnp.int32)
    init = (mask, cycle0, P[cycle0], jnp.zeros((K + 1, K + 1), jnp.int32), jnp.full((n1,), n1, jnp.int32),
            jnp.int32(0))
    _, cycle, _, cycles, first, m = jax.lax.while_loop(cond, body, init)
    cycles = cycles.at[jnp.minimum(m, K)].set(cycle)
    return cycles, jnp.minimum(first, size)


def build_tour(criterion: str, D, beta, psi, mask, resume=None):
    """``BuildTour_K`` (Algorithm 2) for ``criterion`` in :data:`BUILDERS`; returns ``(tour, reward)``.

    ``resume = (cycle0, m0)`` (GI only) continues from a partial tour, see :func:`_gi_tour`.
    """
    if resume is not None and criterion != "gi":
        raise ValueError(f"only the builder 'gi' can resume from a partial tour, got {criterion!r}")
    if criterion == "gi":
        tour = _gi_tour(D, beta, psi, mask, *(resume or ()))
    elif criterion in APPEND_CRITERIA:
        tour = _append_tour(criterion, D, beta, psi, mask)
    else:
        raise ValueError(f"builder must be one of {BUILDERS}, got {criterion!r}")
    return tour, tour_reward(D, beta, psi, tour)


@partial(jax.jit, static_argnames="criterion")
def build_tour_jit(criterion, D, beta, psi, mask):
    """Jitted :func:`build_tour`."""
    return build_tour(criterion, D, beta, psi, mask)


@partial(jax.jit, static_argnames="criterion")
def build_tours_batch(criterion, D, beta, psi, masks):
    """:func:`build_tour` vmapped over a batch: ``D [B, K+1, K+1]``, ``beta [B, K+1]``, ``psi [B]``, ``masks [B, K+1]``."""
    return jax.vmap(partial(build_tour, criterion))(D, beta, psi, masks)
