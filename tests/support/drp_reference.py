"""Plain-Python transcriptions of chapter 3's equations and algorithms: the test oracle.

Written literally from the thesis text (rho of extended partial tours,
Algorithms 1, 3, 4), independent of the array programs in ``jaxdc.drp``.
Graphs are ``(D, beta, psi)`` with ``D`` a list of lists, node 0 the base and
``beta[0] = alpha``. Tours are lists of node indices without the base.
Ties: lowest node index first (for GI, then earliest position); for the
clusterings, the first pair in (i, j) order of the slot list.
"""

from __future__ import annotations

import heapq
import itertools


def rho(D, beta, psi, t, cyclic=False):
    """Reward (gain) of a partial tour ``t`` = (0, t[0], ...): sum of P_t(v) beta(v); cyclic adds the return to 0."""
    total, dist, prev = 0.0, 0.0, 0
    for v in t:
        dist += D[prev][v]
        total += psi ** dist * beta[v]
        prev = v
    if cyclic:
        total += psi ** (dist + D[prev][0]) * beta[0]
    return total


def tour_reward(D, beta, psi, t):
    """Eq. 3.1 for one tour: sum_{v in t\\0} P_t(v) beta(v) - (1 - P_t(0)) alpha; empty tour 0."""
    if not t:
        return 0.0
    return rho(D, beta, psi, t, cyclic=True) - beta[0]


def expected_reward(D, beta, psi, plan):
    return sum(tour_reward(D, beta, psi, t) for t in plan)


def _delta(D, beta, psi, t, u, v):  # Eq. 3.4
    r = rho(D, beta, psi, t)
    return (rho(D, beta, psi, t + [v]) - r) - (rho(D, beta, psi, t + [u, v]) - rho(D, beta, psi, t + [u]))


def pick(criterion, D, beta, psi, t, C):
    """The append criteria, Eqs. 3.2-3.7: returns the chosen node."""
    r = rho(D, beta, psi, t)
    best, best_u = None, None
    for u in sorted(C):
        others = [v for v in sorted(C) if v != u]
        ng = rho(D, beta, psi, t + [u]) - r  # Eq. 3.2
        if criterion == "ng":
            s = ng
        elif criterion == "osa":  # Eq. 3.3 (no other v: just NG)
            s = max((rho(D, beta, psi, t + [u, v]) - r for v in others), default=ng)
        elif criterion == "tl":  # Eq. 3.5, minimised
            s = -sum(_delta(D, beta, psi, t, u, v) for v in others)
        elif criterion == "gml":  # Eq. 3.6
            s = ng - min((_delta(D, beta, psi, t, u, v) for v in others), default=0.0)
        elif criterion == "lpg":  # Eq. 3.7, minimised
            tl = sum(_delta(D, beta, psi, t, u, v) for v in others)
            s = -(tl / ng) if ng > 0 else -float("inf")
        else:
            raise ValueError(criterion)
        if best is None or s > best:
            best, best_u = s, u
    return best_u


def build_tour(criterion, D, beta, psi, C):
    """Algorithm 2."""
    C, t = set(C), []
    while C:
        if criterion == "gi":  # Eq. 3.8 on the cyclic tour, beta(0) = alpha
            base = rho(D, beta, psi, t, cyclic=True)
            best = None
            for u in sorted(C):
                for i in range(len(t) + 1):  # insert after the i-th node (0 = the base)
                    s = rho(D, beta, psi, t[:i] + [u] + t[i:], cyclic=True) - base
                    if best is None or s > best[0]:
                        best = (s, u, i)
            _, u, i = best
            t = t[:i] + [u] + t[i:]
        else:
            u = pick(criterion, D, beta, psi, t, C)
            t = t + [u]
        C.discard(u)
    return t


def nc(D, beta, psi, evaluate):
    """Algorithm 1 with evaluator R(cluster) -> reward. Returns the list of clusters (sorted lists)."""
    S = [[v] for v in range(1, len(D))]
    while True:
        best, pair = 0.0, None
        for i in range(len(S)):
            for j in range(i + 1, len(S)):
                d = evaluate(S[i] + S[j]) - evaluate(S[i]) - evaluate(S[j])
                if d > best:
                    best, pair = d, (i, j)
        if pair is None:
            return S
        i, j = pair
        S[i] = sorted(S[i] + S[j])
        del S[j]


def pgc_merge(D, beta, psi, alpha, ci, cj):
    """Algorithm 3. A cluster is a dict with C, e, l, g, c, L (adjacency dict)."""
    if D[0][ci["e"]] > D[0][cj["e"]]:
        ci, cj = cj, ci
    d, vi_, vj_ = float("inf"), None, None
    for vi in sorted(ci["C"]):
        for vj in sorted(cj["C"]):
            if D[vi][vj] < d:
                d, vi_, vj_ = D[vi][vj], vi, vj
    L = {v: list(n) for v, n in ci["L"].items()}
    L.update({v: list(n) for v, n in cj["L"].items()})
    L.setdefault(vi_, []).append(vj_)
    L.setdefault(vj_, []).append(vi_)
    H = [(D[vi_][vj_], vj_)]
    M = set(ci["C"])
    l, g = ci["l"], ci["g"]
    while H:
        d, v = heapq.heappop(H)
        if v in M:
            continue
        l += d
        g += psi ** (D[0][ci["e"]] + l) * beta[v]
        M.add(v)
        for u in cj["L"].get(v, []):
            if u not in M:
                heapq.heappush(H, (D[u][v], u))
    c = (1 - psi ** (D[0][ci["e"]] + D[0][cj["e"]] + l)) * alpha
    return {"C": sorted(ci["C"] + cj["C"]), "e": ci["e"], "l": l, "g": g, "c": c, "L": L}


def pgc(D, beta, psi, alpha):
    """Algorithm 4. Returns the final cluster records."""
    S = [{"C": [v], "e": v, "l": 0.0, "g": psi ** D[0][v] * beta[v],
          "c": (1 - psi ** (2 * D[0][v])) * alpha, "L": {}} for v in range(1, len(D))]
    while True:
        best, pair = 0.0, None
        for i in range(len(S)):
            for j in range(i + 1, len(S)):
                k = pgc_merge(D, beta, psi, alpha, S[i], S[j])
                d = (k["g"] - k["c"]) - (S[i]["g"] - S[i]["c"]) - (S[j]["g"] - S[j]["c"])
                if d > best:
                    best, pair = d, (i, j, k)
        if pair is None:
            return S
        i, j, k = pair
        S[i] = k
        del S[j]


def brute_force(D, beta, psi):
    """Optimal plan by enumerating every set partition of every subset and every order."""
    n = len(D) - 1
    best_tour = {}
    for r in range(1, n + 1):
        for sub in itertools.combinations(range(1, n + 1), r):
            best_tour[sub] = max(tour_reward(D, beta, psi, list(p)) for p in itertools.permutations(sub))

    def partitions(items):
        if not items:
            yield []
            return
        first, rest = items[0], items[1:]
        for p in partitions(rest):
            yield [[first]] + p
            for k in range(len(p)):
                yield p[:k] + [[first] + p[k]] + p[k + 1:]

    best = 0.0
    for r in range(0, n + 1):
        for sub in itertools.combinations(range(1, n + 1), r):
            for p in partitions(list(sub)):
                best = max(best, sum(best_tour[tuple(sorted(b))] for b in p))
    return best


def graph_batch(seeds, n=7, rewards="1-9", size=40, psi=0.99):
    """``(D, beta, psi)`` arrays of generated graphs (one per seed, robot value 0) for the array programs."""
    import jax.numpy as jnp

    from jaxdc.drp import world

    gs = [world.generate(s, n=n, size=size, rewards=rewards) for s in seeds]
    D = jnp.stack([world.distances(g.base, g.nodes) for g in gs])
    beta = jnp.stack([world.node_values(g.rewards, 0.0) for g in gs])
    return D, beta, jnp.full((len(gs),), psi, jnp.float32)
