"""Exact DRP solver for small instances (n <= 9), beyond the thesis.

Two dynamic programmes over subsets of the nodes:

1. Best single tour over exactly the set ``S`` (Eq. 3.1 for one tour). Since a
   robot at ``v`` gains ``psi^D(v, w) (beta(w) + rest)`` by going to ``w`` next,
   the suffix value ``f(R, v)`` of visiting the remaining set ``R`` from ``v``
   and returning obeys ``f(R, v) = max_{w in R} psi^D(v, w) (beta(w) + f(R \\ w, w))``
   with ``f({}, v) = psi^D(v, 0) alpha``; the tour's reward is ``f(S, 0) - alpha``.
2. Best plan: a partition of a subset of the nodes into tours (nodes may be
   left unvisited): ``B(S) = max(B(S \\ low), max_{T ∋ low} tour(T) + B(S \\ T))``.

O(2^n n^2 + 3^n): milliseconds for n = 9.
"""

from __future__ import annotations

import numpy as np

MAX_NODES = 9


def solve(D, beta, psi):
    """Optimal expected reward and plan. ``D [n+1, n+1]``, ``beta [n+1]`` with ``beta[0] = alpha``.

    Returns ``(value, tours)`` with tours as lists of node indices (1..n), visiting order.
    """
    D = np.asarray(D, np.float64)
    beta = np.asarray(beta, np.float64)
    n = D.shape[0] - 1
    if not 1 <= n <= MAX_NODES:
        raise ValueError(f"exact solver needs 1 <= n <= {MAX_NODES} nodes, got n={n}")
    P = float(psi) ** D
    full = 1 << n
    f = np.full((full, n + 1), -np.inf)
    nxt = np.zeros((full, n + 1), np.int64)
    f[0, :] = P[:, 0] * beta[0]
    for R in range(1, full):
        members = [w for w in range(n) if R >> w & 1]
        for v in range(n + 1):
            if v and R >> (v - 1) & 1:
                continue
            best, arg = -np.inf, 0
            for w in members:
                val = P[v, w + 1] * (beta[w + 1] + f[R ^ (1 << w), w + 1])
                if val > best:
                    best, arg = val, w + 1
            f[R, v], nxt[R, v] = best, arg
    tour_value = f[:, 0] - beta[0]
    tour_value[0] = 0.0
    B = np.zeros(full)
    choice = np.zeros(full, np.int64)  # the tour set containing the lowest node, 0 = leave it unvisited
    for S in range(1, full):
        low = S & -S
        best, arg = B[S ^ low], 0
        rest = S ^ low
        sub = rest
        while True:
            T = sub | low
            val = tour_value[T] + B[S ^ T]
            if val > best:
                best, arg = val, T
            if sub == 0:
                break
            sub = (sub - 1) & rest
        B[S], choice[S] = best, arg
    tours, S = [], full - 1
    while S:
        T = choice[S]
        if T == 0:
            S ^= S & -S
            continue
        tour, v, R = [], 0, T
        while R:
            w = int(nxt[R, v])
            tour.append(w)
            R ^= 1 << (w - 1)
            v = w
        tours.append(tour)
        S ^= T
    return float(B[full - 1]), tours
