"""The append builders' tour cache for NC (section 3.4.1 with Algorithm 5's evaluator).

The append criteria NG, OSA, TL, GML and LPG never look at ``beta(0) = alpha``,
so the tour over a node set is the same for every robot value; its reward
``R(C) = collected + P_t(0) alpha - alpha`` follows from the two alpha-free
parts (:func:`jaxdc.drp.evaluate.evaluate_parts`). The cache keeps those parts
per ``(graph, node set)``, so each node set's tour is built once for all robot
values of a graph and all NC rounds.
"""

from __future__ import annotations

import numpy as np

from jaxdc.drp.evaluate import combine, evaluate_parts


class TourCache:
    """``(graph, node set) -> (collected, p_return)`` for the append builder ``criterion``.

    ``D``, ``beta``, ``psi``: the batch's arrays; ``P = psi**D`` and ``host``
    (:func:`jaxdc.drp.evaluate.host_arrays`) as at hand. ``built`` counts the
    tours built so far.
    """

    def __init__(self, criterion, D, beta, psi, P, host):
        self.criterion = criterion
        self.arrays = (D, beta, psi)
        self.P, self.host = P, host
        self.index = {}
        self.collected = np.zeros(0, np.float64)
        self.p_return = np.zeros(0, np.float64)
        self.built = 0

    def rewards(self, gidx, masks, alpha):
        """``R(C)`` (float64) of the node sets ``masks [J, n+1]`` of graphs ``gidx [J]`` at robot values
        ``alpha [J]``; node sets not seen before are built (once each) and stored."""
        gidx = np.asarray(gidx, np.int32)
        masks = np.asarray(masks, bool)
        keys = np.concatenate([gidx.astype("<i4").view(np.uint8).reshape(-1, 4), np.packbits(masks, axis=1)], 1)
        keys = np.ascontiguousarray(keys).view(np.dtype((np.void, keys.shape[1])))[:, 0]
        uniq, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        slot = np.array([self.index.get(k.tobytes(), -1) for k in uniq], np.int64)
        new = np.flatnonzero(slot < 0)
        if len(new):
            rows = first[new]
            c, p = evaluate_parts(self.criterion, *self.arrays, gidx[rows], masks[rows], self.P, self.host)
            base = len(self.collected)
            self.collected = np.concatenate([self.collected, c])
            self.p_return = np.concatenate([self.p_return, p])
            slot[new] = base + np.arange(len(new))
            for k, s in zip(uniq[new], slot[new]):
                self.index[k.tobytes()] = int(s)
            self.built += len(new)
        s = slot[inverse.reshape(-1)]
        return combine(self.collected[s], self.p_return[s], alpha)
