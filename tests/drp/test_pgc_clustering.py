"""PGC (Algorithms 3-4) against the transcription, and its k-MST records."""

import numpy as np
import pytest

from jaxdc.drp import world
from jaxdc.drp.pgc_clustering import PGCCluster, PGCResult, pgc, pgc_merge
from tests.support import drp_reference as ref

ALPHAS = [0.0, 10.0, 25.0, 40.0]


def test_pgc_matches_transcription():
    for seed in range(4):
        for a in ALPHAS:
            g = world.generate(seed, n=8, size=40, rewards="4-6", alpha=a)
            D, beta, _ = world.arrays(g)
            Dl, bl = np.asarray(D, float).tolist(), np.asarray(beta, float).tolist()
            res = pgc(np.asarray(D, float), np.asarray(beta, float), 0.99, a)
            want = ref.pgc(Dl, bl, 0.99, a)
            assert res.clusters == [r["C"] for r in want]
            assert res.clusters == [r.nodes for r in res.records]
            for got, r in zip(res.records, want):
                assert (got.entry, got.length, got.gain, got.cost) == pytest.approx((r["e"], r["l"], r["g"], r["c"]))


def test_pgc_kmst_bookkeeping_against_direct_computation():
    g = world.generate(3, n=30, size=60, alpha=30.0)
    D, beta, _ = world.arrays(g)
    Dn = np.asarray(D, float)
    res = pgc(Dn, np.asarray(beta, float), 0.99, 30.0)
    assert isinstance(res, PGCResult)
    clusters, records, edges = res
    assert len(clusters) < 30  # something merged
    for C, rec in zip(clusters, records):
        assert isinstance(rec, PGCCluster) and rec.nodes == C and rec.value == rec.gain - rec.cost
        mine = [(u, v) for u, v in edges if u in C]
        assert all(v in C for _, v in mine)
        # a spanning tree of C: |C| - 1 edges, connected
        assert len(mine) == len(C) - 1
        seen, todo = {C[0]}, [C[0]]
        while todo:
            x = todo.pop()
            for u, v in mine:
                for a, b in ((u, v), (v, u)):
                    if a == x and b not in seen:
                        seen.add(b)
                        todo.append(b)
        assert seen == set(C)
        # the length is the total edge length of that tree, the entry the member closest to the base
        assert rec.length == pytest.approx(sum(Dn[u, v] for u, v in mine))
        assert rec.entry == C[int(np.argmin(Dn[0, C]))]
        if len(C) == 1:
            assert rec.gain == pytest.approx(0.99 ** Dn[0, rec.entry] * float(beta[rec.entry]))
            assert rec.cost == pytest.approx((1 - 0.99 ** (2 * Dn[0, rec.entry])) * 30.0)


def test_pgc_merge_of_two_singletons_is_the_exact_two_node_tour():
    g = world.generate(2, n=2, size=30, alpha=12.0)
    D, beta, _ = world.arrays(g)
    res = pgc(np.asarray(D, float), np.asarray(beta, float), 0.99, 12.0)
    Dl, bl = np.asarray(D, float).tolist(), np.asarray(beta, float).tolist()
    if len(res.clusters) == 1:
        rec = res.records[0]
        other = 3 - rec.entry
        assert rec.value == pytest.approx(ref.tour_reward(Dl, bl, 0.99, [rec.entry, other]), rel=1e-6)


def test_pgc_merge_matches_the_transcription():
    g = world.generate(4, n=6, size=40, alpha=10.0)
    D, beta, _ = world.arrays(g)
    Dn, bn = np.asarray(D, float), np.asarray(beta, float)
    Dl, bl = Dn.tolist(), bn.tolist()

    def single(v):
        return PGCCluster([v], v, 0.0, 0.99 ** Dn[0, v] * bn[v], (1 - 0.99 ** (2 * Dn[0, v])) * 10.0)

    def ref_single(v):
        c = single(v)
        return {"C": [v], "e": v, "l": 0.0, "g": c.gain, "c": c.cost, "L": {}}

    merged, edge = pgc_merge(Dn, bn, 0.99, 10.0, {v: [] for v in range(1, 7)}, single(5), single(2))
    want = ref.pgc_merge(Dl, bl, 0.99, 10.0, ref_single(5), ref_single(2))
    assert merged.nodes == [2, 5] and sorted(edge) == [2, 5]
    assert (merged.entry, merged.length, merged.gain, merged.cost) == pytest.approx(
        (want["e"], want["l"], want["g"], want["c"]))
