"""The six tour builders of section 3.4.2 (Algorithm 2, Eqs. 3.2-3.8) as array programs.

:func:`build_tour` takes ``(D, beta, psi, mask)`` for one cluster
(:func:`build_order`, the tour alone, takes ``P = psi**D`` instead of ``D, psi``):

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
from typing import NamedTuple

import jax
import jax.numpy as jnp

from jaxdc.core.tour_criteria import APPEND_CRITERIA, append_scores
from jaxdc.drp.world import tour_reward

#: Builders in the thesis' order (Table 3.1).
BUILDERS = APPEND_CRITERIA + ("gi",)


#: Criteria whose pairwise term is a maximum or minimum over the other candidates (Eqs. 3.3, 3.6): exact
#: whatever the order of the entries, so their loop may drop assigned columns (:func:`_append_phases`).
_PAIRWISE_EXTREMA = ("osa", "gml")


def _append_phases(criterion, n):
    """Static phases of :func:`_append_tour` for ``K = n``: ``(end, cols)`` per phase.

    OSA and GML score a ``[K, K]`` block per step (Eqs. 3.3, 3.6), but only the
    unassigned nodes take part, and at most ``n - start`` are left when a phase
    starts; above ``K = 32`` the loop runs in quarters, each on that many
    columns (about half the block entries of a single phase). The other
    criteria, and small ``K``, keep one phase over all ``K + 1`` columns: TL's
    and LPG's sums would change their float32 rounding if zeros were dropped.
    """
    if criterion not in _PAIRWISE_EXTREMA or n <= 32:
        return ((n, n + 1),)
    ends = [n * j // 4 for j in range(1, 4)] + [n]
    return tuple((e, n - s) for s, e in zip([0] + ends[:-1], ends))


def _append_tour(criterion, P, beta, mask):
    """Algorithm 2 with an append criterion: always insert at position ``|t|``. ``P = psi**D``.

    Each phase of :func:`_append_phases` gathers ``P`` and ``beta`` of its
    columns -- the unassigned nodes in index order, so the candidates' scores
    are the same numbers and the lowest node still wins a tie.
    """
    n = P.shape[0] - 1
    mask = jnp.asarray(mask, bool).at[0].set(False)
    tour = jnp.full((n,), -1, jnp.int32)
    end, p_end, s = jnp.int32(0), jnp.float32(1.0), jnp.int32(0)
    for limit, width in _append_phases(criterion, n):
        full = width == n + 1  # all columns: the arrays as they are
        cols = jnp.arange(n + 1) if full else jnp.argsort(~mask, stable=True)[:width]
        Pc, bc = (P, beta) if full else (P[cols[:, None], cols[None, :]], beta[cols])

        def cond(st, limit=limit):
            cmask, _, _, _, s = st
            return (s < limit) & cmask.any()

        def body(st, cols=cols, Pc=Pc, bc=bc, full=full):
            cmask, end, p_end, tour, s = st
            scores = append_scores(criterion, P[end] if full else P[end][cols], Pc, bc, cmask, p_end)
            c = jnp.argmax(scores)
            u = cols[c]
            return cmask.at[c].set(False), u, p_end * P[end, u], tour.at[s].set(u), s + 1

        init = (mask if full else mask[cols], end, p_end, tour, s)
        cmask, end, p_end, tour, s = jax.lax.while_loop(cond, body, init)
        mask = cmask if full else jnp.zeros_like(mask).at[cols].set(cmask)
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


def _gi_phases(n):
    """Static phases of :func:`_gi_tour` for ``K = n``: ``(end, rows, cols)`` per phase.

    A phase runs while the partial tour has ``m < end`` nodes. Slots fill in insertion
    order, so the used slots are among the first ``rows``; at most ``n - start``
    nodes are still unassigned when it starts, so ``cols`` columns hold them all.
    Two phases (halves) up to ``K = 32``, four (quarters) above, where the
    ``[rows, cols]`` block is the work: about ``0.31 K^3`` entries per build
    instead of ``0.75 K^3`` with halves over all columns.
    """
    q = 4 if n > 32 else 2
    ends = sorted({(n + 2) * j // q for j in range(1, q)} | {n})
    out, start = [], 0
    for e in ends:
        if e > start and start < n:
            out.append((min(e, n), n + 1 if e >= n else e, max(n - start, 1)))
        start = e
    return tuple(out)


class _GIState(NamedTuple):
    """The loop state of :func:`_gi_tour`: slots in insertion order (slot 0 is the base), columns compacted
    to the candidate nodes of the phase."""

    cols: jax.Array  # [W] the graph node of each column, in index order
    cmask: jax.Array  # [W] bool: the column's node is still unassigned
    order: jax.Array  # [K+1] order[j]: the slot at tour position j
    pos: jax.Array  # [K+1] pos[s]: the tour position of slot s
    node: jax.Array  # [K+1] node[s]: the node in slot s
    rows: jax.Array  # [K+1, W] P[node[s], cols]
    fac: jax.Array  # [K+1, W] 1 - P(a, u) P(u, b) / P(a, b) for the edge leaving slot s's node a
    m: jax.Array  # the number of nodes in the partial tour


def _gi_tour(P, beta, mask, cycle0=None, m0=0):
    """Greedy Insertion (GI, Eq. 3.8): the best node at the best position, cyclic tour. ``P = psi**D``.

    ``cycle0`` (``[K+1]``, base at 0, zeros after position ``m0``) resumes GI from a
    partial tour of ``m0`` nodes, as if its first ``m0`` insertions had been made
    here; ``mask`` then holds only the nodes still to insert. GI's score of a
    (position, node) pair depends on the partial tour only, not on the other
    unassigned nodes, so a run over ``C`` agrees with a run over a subset of ``C``
    until the first insertion of a node outside it (used by
    :func:`jaxdc.drp.nc_clustering.nc` via :func:`gi_trajectory`).

    The scores are those of :func:`gi_scores`, computed with the same float32
    operations, but the ``[K+1, K+1]`` blocks are kept in *slot* order (the order
    in which tour nodes were inserted) rather than in tour order. Inserting ``u``
    after ``a`` (successor ``b``) then changes two rows only: the edge ``(a, b)``
    becomes ``(a, u)`` and ``(u, b)`` is new. So the per-edge factor
    ``1 - P(a, u') P(u', b) / P(a, b)`` of Eq. 3.8 is computed once per edge and
    kept, instead of for every edge at every step; only the ``[K+1]`` vectors
    ``P_t(a)`` and "value after ``a``" are recomputed, in tour order, as in
    :func:`gi_scores`. The loop runs in phases (:func:`_gi_phases`): slots fill
    from the top, so a phase scores only the rows that can be used in it, and at
    its start the columns are compacted to the nodes still unassigned (in index
    order, so the same entries are computed and the lowest node still wins a
    tie). ``pos`` (the tour position of each slot) is kept up to date rather than
    recomputed, the position of the chosen node is picked on its own column
    (recomputed with the same operations), and rows are replaced with selects,
    not scatters (a vmapped ``.at[i].set`` is a scatter per step). The loop state
    is a :class:`_GIState`. Ties: lowest node, then earliest tour position.
    """
    n = P.shape[0] - 1
    mask = jnp.asarray(mask, bool).at[0].set(False)
    k = jnp.arange(n + 1)
    tiny = jnp.finfo(jnp.float32).tiny
    cycle0 = jnp.zeros((n + 1,), jnp.int32) if cycle0 is None else jnp.asarray(cycle0, jnp.int32)
    m0 = jnp.asarray(m0, jnp.int32)

    def factor(p_a, p_b, p_ab):
        """``1 - P(a, u) P(u, b) / P(a, b)`` for every ``u``: Eq. 3.8's discount of what follows ``a``."""
        return 1.0 - p_a * p_b / jnp.maximum(p_ab, tiny)

    def cond(limit):
        def go(st: _GIState):
            return (st.m < limit) & st.cmask.any()
        return go

    def body(h):
        """One insertion, scoring only the first ``h`` slots (valid while ``m < h``)."""

        def step(st: _GIState) -> _GIState:
            cols, cmask, order, pos, node, rows, fac, m = st
            # Tour-order vectors, exactly as in gi_scores: order[j] is the slot at tour position j.
            inside = k <= m
            cyc = node[order]
            nxt = jnp.where(k < m, jnp.roll(cyc, -1), 0)
            edge = jnp.where(inside, P[cyc, nxt], 1.0)
            reach = jnp.cumprod(jnp.concatenate([jnp.ones((1,), edge.dtype), edge[:-1]]))
            collected = jnp.where((k >= 1) & inside, reach * beta[cyc], 0.0)
            home = jnp.prod(edge) * beta[0]
            after = collected.sum() - jnp.cumsum(collected) + home
            ph = pos[:h]
            score = reach[ph][:, None] * rows[:h] * beta[cols][None, :] - fac[:h] * after[ph][:, None]
            score = jnp.where((k[:h] <= m)[:, None] & cmask[None, :], score, -jnp.inf)
            best = score.max(axis=0)
            c = jnp.argmax(best)  # lowest node: cols is in index order
            u = cols[c]
            col = reach[ph] * rows[:h, c] * beta[u] - fac[:h, c] * after[ph]
            col = jnp.where(k[:h] <= m, col, -jnp.inf)
            slot = jnp.argmin(jnp.where(col == col.max(), ph, n + 1))  # then earliest position
            i = pos[slot]
            new = m + 1
            a, b = node[slot], nxt[i]
            p_u = P[u][cols]
            f_slot = factor(rows[slot], p_u, P[a, u])
            f_new = factor(p_u, P[b][cols], P[u, b])
            kk = k[:, None]
            fac = jnp.where(kk == slot, f_slot[None, :], jnp.where(kk == new, f_new[None, :], fac))
            rows = jnp.where(kk == new, p_u[None, :], rows)
            node = jnp.where(k == new, u, node)
            order = jnp.where(k <= i, order, jnp.where(k == i + 1, new, jnp.where(k <= new, jnp.roll(order, 1), k)))
            pos = jnp.where(k == new, i + 1, jnp.where(pos > i, pos + 1, pos))
            cmask = cmask & (jnp.arange(cmask.shape[0]) != c)
            return _GIState(cols, cmask, order.astype(jnp.int32), pos.astype(jnp.int32), node, rows, fac, new)

        return step

    def compact(st: _GIState, width) -> _GIState:
        """Keep ``width`` columns: the unassigned nodes first, in index order (a stable sort)."""
        keep = jnp.argsort(~st.cmask, stable=True)[:width]
        return st._replace(cols=st.cols[keep], cmask=st.cmask[keep], rows=st.rows[:, keep], fac=st.fac[:, keep])

    # Initial slots: the partial tour cycle0 in tour order.
    rows0 = P[cycle0]
    nxt0 = jnp.where(k < m0, jnp.roll(cycle0, -1), 0)
    p_ub0 = jnp.where((k < m0)[:, None], jnp.roll(rows0, -1, axis=0), P[0][None, :])
    edge0 = jnp.where(k <= m0, P[cycle0, nxt0], 1.0)
    fac0 = factor(rows0, p_ub0, edge0[:, None])
    st = _GIState(cols=k.astype(jnp.int32), cmask=mask, order=k.astype(jnp.int32), pos=k.astype(jnp.int32),
                  node=cycle0, rows=rows0, fac=fac0, m=m0)
    for end, h, width in _gi_phases(n):
        st = jax.lax.while_loop(cond(end), body(h), compact(st, width))
    cycle = st.node[st.order]
    return jnp.where(k[1:] <= st.m, cycle[1:], -1)


class _TrajectoryState(NamedTuple):
    """The loop state of :func:`gi_trajectory`."""

    mask: jax.Array  # [n+1] bool: the cluster's nodes still to insert
    cycle: jax.Array  # [K+1] the partial cyclic tour, base first, zero-padded
    rows: jax.Array  # [K+1, n+1] P[cycle]
    cycles: jax.Array  # [K+1, K+1] cycles[m]: the partial tour before step m
    first: jax.Array  # [n+1] the first step at which each outside node cuts in (n+1 while none)
    m: jax.Array  # the step


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

    def cond(st: _TrajectoryState):
        return st.m < size

    def body(st: _TrajectoryState) -> _TrajectoryState:
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
        return _TrajectoryState(mask.at[u].set(False), cycle, rows, cycles, first, m + 1)

    cycle0 = jnp.zeros((K + 1,), jnp.int32)
    init = _TrajectoryState(mask, cycle0, P[cycle0], jnp.zeros((K + 1, K + 1), jnp.int32),
                            jnp.full((n1,), n1, jnp.int32), jnp.int32(0))
    st = jax.lax.while_loop(cond, body, init)
    cycles = st.cycles.at[jnp.minimum(st.m, K)].set(st.cycle)
    return cycles, jnp.minimum(st.first, size)


def build_order(criterion: str, P, beta, mask, resume=None):
    """The tour of ``BuildTour_K`` (Algorithm 2) from ``P = psi**D``: ``[K]`` indices, padded with ``-1``.

    ``resume = (cycle0, m0)`` (GI only) continues from a partial tour, see :func:`_gi_tour`.
    """
    if resume is not None and criterion != "gi":
        raise ValueError(f"only the builder 'gi' can resume from a partial tour, got {criterion!r}")
    if criterion == "gi":
        return _gi_tour(P, beta, mask, *(resume or ()))
    if criterion in APPEND_CRITERIA:
        return _append_tour(criterion, P, beta, mask)
    raise ValueError(f"builder must be one of {BUILDERS}, got {criterion!r}")


def build_tour(criterion: str, D, beta, psi, mask, resume=None):
    """``BuildTour_K`` (Algorithm 2) for ``criterion`` in :data:`BUILDERS`; returns ``(tour, reward)``.

    ``resume = (cycle0, m0)`` (GI only) continues from a partial tour, see :func:`_gi_tour`.
    """
    tour = build_order(criterion, psi ** D, beta, mask, resume)
    return tour, tour_reward(D, beta, psi, tour)


@partial(jax.jit, static_argnames="criterion")
def build_tour_jit(criterion, D, beta, psi, mask):
    """Jitted :func:`build_tour`."""
    return build_tour(criterion, D, beta, psi, mask)


@partial(jax.jit, static_argnames="criterion")
def build_tours_batch(criterion, D, beta, psi, masks):
    """:func:`build_tour` vmapped over a batch: ``D [B, K+1, K+1]``, ``beta [B, K+1]``, ``psi [B]``,
    ``masks [B, K+1]``."""
    return jax.vmap(partial(build_tour, criterion))(D, beta, psi, masks)
