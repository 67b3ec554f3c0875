"""NC: the naive agglomerative clustering, Algorithm 1, with a tour builder as evaluator (Algorithm 5).

``R(C)`` is the reward (Eq. 3.1) of the tour the builder makes over *all* of
``C`` (the thesis' "small modification", ``BuildTour'``). :func:`nc` runs many
instances (graphs x robot values) in lockstep: the bookkeeping is vectorised
NumPy, and the tour builds of one round, over all instances, go to one jitted,
vmapped call per cluster-size bucket (:mod:`jaxdc.drp.evaluate`). After a merge
only the pairs that involve the new cluster are re-evaluated; the initial
all-pairs round is one batched call. For the append builders (whose tours do
not depend on alpha) a tour is built once per (graph, node set) and shared by
all robot values and rounds (:class:`jaxdc.drp.tour_cache.TourCache`); GI's
tours depend on alpha and are not shared.

Clusters are identified by their *slot*, the smallest node index in them; the
cluster list ``S`` of Algorithm 1 is kept in slot order, so "the first pair
``(i, j)`` with the largest gain" breaks ties. A merge needs a gain strictly
above 0 (Algorithm 1, line 11 with ``Delta* = 0``).
"""

from __future__ import annotations

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from jaxdc.core.validate import check_choice
from jaxdc.drp.batching import bucket, width
from jaxdc.drp.evaluate import combine, evaluate_clusters, evaluate_parts, gi_trajectories, host_arrays
from jaxdc.drp.tour_cache import TourCache
from jaxdc.drp.tours import BUILDERS


@dataclass(frozen=True)
class _Batch:
    """The instances NC clusters together and how their clusters are evaluated."""

    criterion: str
    D: object  # [G, n+1, n+1] float32
    beta: object  # [G, n+1] float32
    psi: object  # [G] float32
    P: object  # psi**D
    host: tuple  # float64 (D, beta, psi), jaxdc.drp.evaluate.host_arrays
    gidx: np.ndarray  # [I] int32
    alpha: np.ndarray  # [I] float32
    cache: TourCache | None
    resume: bool

    def rewards(self, inst, masks):
        """``R(C)`` of the clusters ``masks [J, n+1]`` of the instances ``inst [J]``, built from scratch."""
        return evaluate_clusters(self.criterion, self.D, self.beta, self.psi, self.gidx[inst], self.alpha[inst],
                                 masks, P=self.P, host=self.host)

    def parts(self, g, masks):
        """``(collected, p_return)`` of the append-builder tours of ``masks`` on graph ``g``."""
        return evaluate_parts(self.criterion, self.D, self.beta, self.psi, np.full(len(masks), g, np.int32),
                              masks, self.P, self.host)


@dataclass
class _State:
    """Algorithm 1's bookkeeping for ``I`` instances over ``n + 1`` slots (slot 0, the base, is unused)."""

    member: np.ndarray  # [I, n+1, n+1] bool: member[i, s] is the cluster in slot s
    alive: np.ndarray  # [I, n+1] bool: slot s holds a cluster
    size: np.ndarray  # [I, n+1] int32: |C_s|
    R: np.ndarray  # [I, n+1] float64: R(C_s)
    Rpair: np.ndarray  # [I, n+1, n+1] float64: R(C_s ∪ C_t) for live s < t, -inf elsewhere
    gain: np.ndarray  # [I, n+1, n+1] float64: R(C_s ∪ C_t) - R(C_s) - R(C_t), -inf where Rpair is
    active: np.ndarray  # [I] bool: the instance may still merge


#: Bytes of the initial round's pair masks (and their member and tour arrays) held at once: the ``n (n - 1) / 2``
#: pairs are evaluated in chunks of whole batches (:func:`_pair_rows`), so that this round needs ``O(n^2)``
#: memory instead of ``O(n^3)``. The rewards do not depend on the chunks (each tour is built on its own).
PAIR_CHUNK_BYTES = 2**26
#: Bytes per pair-mask entry of one chunk: the mask and its two singleton rows (bool), the members and the
#: tours of :func:`jaxdc.drp.evaluate.evaluate` (int32).
PAIR_ENTRY_BYTES = 11


def _pair_rows(n1):
    """Pairs per chunk of the initial round: a multiple of the batch width of the pairs' size bucket, so the
    chunks cut no batch (:func:`jaxdc.drp.batching.bucketed`), with about :data:`PAIR_CHUNK_BYTES` per chunk."""
    w = width((bucket(2, n1 - 1) + 1) ** 2)
    return w * max(1, PAIR_CHUNK_BYTES // (PAIR_ENTRY_BYTES * n1 * w))


def _pair_chunks(eye, a_idx, b_idx):
    """``(part, masks)``: the pairs ``(a_idx, b_idx)[part]`` as node-set masks, :func:`_pair_rows` at a time."""
    rows = _pair_rows(eye.shape[0])
    for start in range(0, len(a_idx), rows):
        part = slice(start, start + rows)
        yield part, eye[a_idx[part]] | eye[b_idx[part]]


def _initial_rewards(batch: _Batch, n1: int):
    """``R`` of every singleton and ``Rpair`` of every pair (Algorithm 1, lines 1-8)."""
    I = len(batch.gidx)
    eye = _slots_eye(n1)
    R = np.zeros((I, n1), np.float64)
    a_idx, b_idx = np.triu_indices(n1 - 1, 1)
    a_idx, b_idx = a_idx + 1, b_idx + 1
    Rpair = np.full((I, n1, n1), -np.inf, np.float64)
    if batch.cache is not None:
        # One build per graph, shared by all its robot values. (No later round asks for a set of size < 3,
        # so they are not stored in the cache.)
        c2, p2 = np.zeros(len(a_idx), np.float64), np.zeros(len(a_idx), np.float64)
        for g in np.unique(batch.gidx):
            c1, p1 = batch.parts(g, eye[1:])
            for part, masks in _pair_chunks(eye, a_idx, b_idx):
                c2[part], p2[part] = batch.parts(g, masks)
            for i in np.flatnonzero(batch.gidx == g):
                R[i, 1:] = combine(c1, p1, batch.alpha[i])
                Rpair[i, a_idx, b_idx] = combine(c2, p2, batch.alpha[i])
    else:
        inst = np.repeat(np.arange(I), n1 - 1)
        nodes = np.tile(np.arange(1, n1), I)
        R[inst, nodes] = batch.rewards(inst, eye[nodes])
        for i in range(I):  # one instance's pairs, a chunk at a time, keeps the mask arrays small
            for part, masks in _pair_chunks(eye, a_idx, b_idx):
                Rpair[i, a_idx[part], b_idx[part]] = batch.rewards(np.full(len(masks), i), masks)
    return R, Rpair


def _slots_eye(n1):
    """``[n+1, n+1]``: row ``s`` is the singleton ``{s}`` (none for the base)."""
    eye = np.eye(n1, dtype=bool)
    eye[0, 0] = False
    return eye


def _initial_state(batch: _Batch, n1: int) -> _State:
    """Every node its own cluster, with the singleton and pair rewards."""
    I = len(batch.gidx)
    alive = np.ones((I, n1), bool)
    alive[:, 0] = False
    R, Rpair = _initial_rewards(batch, n1)
    # gain is kept up to date for the re-evaluated pairs only (the others' terms do not change), with the
    # same float64 operations.
    gain = (Rpair - R[:, :, None]) - R[:, None, :]
    return _State(np.broadcast_to(_slots_eye(n1), (I, n1, n1)).copy(), alive, alive.astype(np.int32), R, Rpair,
                  gain, np.ones(I, bool))


def _best_merges(state: _State):
    """Each active instance's first pair with the largest gain (Algorithm 1, lines 9-11): ``(act, a, b)``
    for the instances whose gain is above 0; the others stop."""
    n1 = state.alive.shape[1]
    act = np.flatnonzero(state.active)
    flat = state.gain[act].reshape(len(act), -1)
    best = flat.argmax(1)
    merge = flat[np.arange(len(act)), best] > 0
    state.active[act[~merge]] = False
    act, best = act[merge], best[merge]
    return act, best // n1, best % n1


def _merge(state: _State, act, a, b):
    """``C_a <- C_a ∪ C_b`` and slot ``b`` emptied in the instances ``act`` (Algorithm 1, lines 12-14)."""
    state.member[act, a] |= state.member[act, b]
    state.member[act, b] = False
    state.alive[act, b] = False
    state.size[act, a] += state.size[act, b]
    state.size[act, b] = 0
    state.R[act, a] = state.Rpair[act, a, b]
    state.Rpair[act, b, :] = -np.inf
    state.Rpair[act, :, b] = -np.inf
    state.gain[act, b, :] = -np.inf
    state.gain[act, :, b] = -np.inf


def _union_rewards(batch: _Batch, state: _State, act, a, rows, ks, masks):
    """``R(C_a ∪ C_k)`` of the pairs ``(rows, ks)`` (rows index ``act``) after a merge into slot ``a``:
    from the tour cache, by resuming GI from the new cluster's trajectory, or built from scratch."""
    inst_j, a_j = act[rows], a[rows]
    if batch.cache is not None:
        return batch.cache.rewards(batch.gidx[inst_j], masks, batch.alpha[inst_j])
    if batch.criterion == "gi" and batch.resume:
        n1 = state.alive.shape[1]
        cycles, first = gi_trajectories(batch.D, batch.beta, batch.psi, batch.gidx[act], batch.alpha[act],
                                        state.member[act, a])
        done = np.where(state.member[inst_j, ks], first[rows], n1).min(1)
        done = np.minimum(done, state.size[inst_j, a_j])
        prefix = np.zeros((len(rows), n1), np.int32)
        prefix[:, : cycles.shape[2]] = cycles[rows, done]
        return evaluate_clusters(batch.criterion, batch.D, batch.beta, batch.psi, batch.gidx[inst_j],
                                 batch.alpha[inst_j], masks, resume=(prefix, done), P=batch.P, host=batch.host)
    return batch.rewards(inst_j, masks)


def _reevaluate(batch: _Batch, state: _State, act, a):
    """Re-evaluate only the pairs ``(new cluster C_a, C_k)`` (Algorithm 1, lines 15-17)."""
    other = state.alive[act].copy()
    other[np.arange(len(act)), a] = False
    rows, ks = np.nonzero(other)
    inst_j, a_j = act[rows], a[rows]
    masks = state.member[inst_j, a_j] | state.member[inst_j, ks]
    r = _union_rewards(batch, state, act, a, rows, ks, masks)
    lo, hi = np.minimum(a_j, ks), np.maximum(a_j, ks)
    state.Rpair[inst_j, lo, hi] = r
    state.gain[inst_j, lo, hi] = (r - state.R[inst_j, lo]) - state.R[inst_j, hi]


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
        depend on alpha; see :func:`jaxdc.drp.evaluate.evaluate_parts`). Same
        result as ``cache=False``. GI's tours depend on alpha, so GI never caches.
      resume: for GI, after a merge run GI once over the new cluster ``C_a``
        (:func:`jaxdc.drp.evaluate.gi_trajectories`) and build each ``C_a ∪ C_k``
        by resuming from the partial tour at the step where a node of ``C_k``
        first cuts in: GI's scores depend on the partial tour only, so the steps
        before are the same (:func:`jaxdc.drp.tours.gi_trajectory`). Same
        clusters as ``resume=False`` (the default, which rebuilds every union
        from scratch); measured *slower* on 100-node graphs (docs/drp.md, Speed),
        since a node of ``C_k`` near the base cuts in at the first steps.

    Returns:
      ``member [I, n+1, n+1]`` bool: ``member[i, s]`` is the cluster in slot ``s``
      (all False for empty slots). Every node is in exactly one cluster.
    """
    check_choice("builder", criterion, BUILDERS)
    D = jnp.asarray(D, jnp.float32)
    beta = jnp.asarray(beta, jnp.float32)
    psi = jnp.asarray(psi, jnp.float32)
    P = psi[:, None, None] ** D
    host = host_arrays(D, beta, psi)
    tc = TourCache(criterion, D, beta, psi, P, host) if cache and criterion != "gi" else None
    batch = _Batch(criterion, D, beta, psi, P, host, np.asarray(gidx, np.int32), np.asarray(alpha, np.float32), tc,
                   resume)
    state = _initial_state(batch, D.shape[1])
    while True:
        act, a, b = _best_merges(state)
        if progress is not None:
            progress()
        if not len(act):
            return state.member
        _merge(state, act, a, b)
        _reevaluate(batch, state, act, a)
