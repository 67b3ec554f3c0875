"""jaxdc.drp.analysis.claims: section 3.5's claims judged on stored experiment rows (yes, no, n/a)."""

from jaxdc.drp.analysis.claims import CLAIMS, judge_claims

ALPHAS = (0, 10, 20, 25, 30, 40, 60)
#: normalised means per builder that follow the thesis' order (GI ≈ TL ≈ LPG > OSA > GML ≈ NG)
LEVEL = {"gi": 1.0, "tl": 0.98, "lpg": 0.97, "osa": 0.8, "gml": 0.6, "ng": 0.59}


def _record(spread=1.0, ratio=0.9, ratio60=0.4, swap_at=None):
    """An experiment record whose NC means fall with alpha, builders ordered as the thesis says (``swap_at``: OSA
    above GI at that alpha), PGC/NC = ``ratio`` below 30 and ``ratio60`` at 60, GI/NG widened by ``spread``."""
    rows = []
    for b, lv in LEVEL.items():
        for a in ALPHAS:
            m = (lv if b != "ng" else lv / spread) * (1 - a / 100)
            if swap_at == a and b == "osa":
                m = 2.0
            sd = 0.02 * (1 + a / 10)
            rows.append({"clustering": "nc", "builder": b, "alpha": a, "mean": m, "sd": sd})
            r = ratio60 if a == 60 else ratio
            rows.append({"clustering": "pgc", "builder": b, "alpha": a, "mean": m * r, "sd": sd, "pgc_over_nc": r})
    return {"config": {"rewards": "4-6", "graphs": 100, "nodes": 100}, "rows": rows}


def _verdicts(exps):
    return {v.claim: v for v in judge_claims(exps)}


def test_claims_hold_on_rows_that_follow_the_text():
    exps = {"4-6": _record(spread=1.2), "1-9": _record(spread=1.5, ratio60=0.5), "5": _record(spread=1.0, ratio60=0.3)}
    got = _verdicts(exps)
    assert len(got) == len(CLAIMS)
    assert {v.agrees for v in got.values()} == {"yes"}, [v for v in got.values() if v.agrees != "yes"]


def test_a_broken_order_and_low_ratios_are_not_reproduced():
    exps = {"4-6": _record(swap_at=20, ratio=0.7, ratio60=0.8)}
    got = _verdicts(exps)
    order = next(v for v in got.values() if v.source == "3.1" and "order" in v.claim)
    assert order.agrees == "no" and "fails at α = 20" in order.ours
    assert next(v for v in got.values() if "above 0.8" in v.claim).agrees == "no"
    assert next(v for v in got.values() if "about 0.4" in v.claim).agrees == "no"


def test_claims_reading_a_missing_experiment_are_na():
    got = _verdicts({"4-6": _record()})
    variance = [v for v in got.values() if v.source == "3.4, 3.5"]
    assert variance and all(v.agrees == "n/a" and "1-9" in v.ours for v in variance)
