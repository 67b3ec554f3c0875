"""The batching scheduler of the cluster evaluations (section 3.4.1's ``R(C)``, evaluated in bulk).

NC evaluates thousands of clusters of many sizes per merge round. They are
grouped into padded size buckets (:func:`bucket`), each bucket cut into chunks
of a fixed width (:func:`width`), and every chunk is one call of a compiled,
vmapped tour program (:func:`bucketed`). Each (builder, bucket, width) is one
compiled program, so buckets and widths are few.
"""

from __future__ import annotations

import numpy as np


def bucket(size, n):
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


def width(area):
    """The batch width of a size bucket whose arrays have ``area`` entries: ``2**19 / area`` jobs,
    rounded down to a power of two, 16 to 4096.

    Each width is one compiled program per (builder, bucket), and XLA takes seconds per
    program on a CPU, so there is one: wide for small clusters, whose calls cost mostly
    their fixed overhead, narrower for large ones, where a part-filled batch wastes work.
    The rewards do not depend on it (they are computed from the tours on the host).
    """
    return 1 << int(np.clip(np.log2(2 ** 19 / area), 4, 12))


def bucketed(sizes, n, run, order=None, area=lambda K: (K + 1) ** 2):
    """Call ``run(K, part, pad)`` for every size bucket ``K`` and chunk of jobs.

    Jobs are grouped by :func:`bucket` of ``sizes``, sorted by ``order``
    (default: their size) so that jobs of similar loop length share a
    ``while_loop``, and cut into chunks of the width of :func:`width`; ``pad``
    is ``part`` padded to its width by repeating its first job.
    """
    sizes = np.asarray(sizes)
    order = sizes if order is None else np.asarray(order)
    buckets = np.array([bucket(s, n) for s in range(n + 1)])[sizes]
    for K in np.unique(buckets):
        sel = np.flatnonzero(buckets == K)
        sel = sel[np.argsort(order[sel], kind="stable")]
        w = width(area(int(K)))
        for start in range(0, len(sel), w):
            part = sel[start:start + w]
            run(int(K), part, np.concatenate([part, np.full(w - len(part), part[0])]))
