"""jaxdc.dcg.analysis.claims: the thesis' claims about its DCG figures beside ours (no games played)."""

from __future__ import annotations

import pytest

from jaxdc.core.claims import Verdict
from jaxdc.dcg.analysis.claims import CLAIMS, TESTS, claims
from jaxdc.dcg.analysis.figures import EXPERIMENTS
from jaxdc.dcg.analysis.measures import Claim, ClaimSet


def _summary(reward, sd=1.0, rpe=0.3, acc=None):
    return {"reward": {"mean": reward, "sd": sd}, "rpe": {"mean": rpe, "sd": 0.1}, "opponent_accuracy": acc,
            "per_strategy": {}, "note": ""}


def test_standard_claims_on_a_hand_example():
    results = {None: {"VNN": _summary(5.0, sd=2.0, rpe=0.40), "IMNN": _summary(5.45, rpe=0.30),
                      "EMNN a=0.001": _summary(5.85, rpe=0.35, acc=0.74),
                      "EMNN a=0.0001": _summary(5.5, rpe=0.45, acc=0.5),
                      "OMN+CoNN": _summary(6.0, sd=0.5, rpe=0.33, acc=0.99)}}
    rows = {c: (o, a) for _, c, o, a in claims(EXPERIMENTS["standard"], results)}
    by_start = {c.split(":")[0]: v for c, v in rows.items()}
    assert by_start["IMNN"] == ("+9.0%", "yes")
    assert by_start["EMNN a=0.001"] == ("+17.0%", "yes")
    assert rows["OMN+CoNN: above +19% episode reward over VNN (Fig. 5.6)"] == ("+20.0%", "yes")
    assert rows["OMN+CoNN: the highest reward with the smallest SD (Fig. 5.6)"][1] == "yes"
    assert rows["EMNN a=0.0001 the best RPE, followed by VNN (Fig. 5.7)"][1] == "yes"
    assert rows["EMNN opponent-action accuracy about 75% (5.5.3)"] == ("74.0%", "yes")
    assert rows["OMN opponent-action accuracy over 98% (5.5.3)"] == ("99.0%", "yes")
    # a worse OMN+CoNN fails its claims
    results[None]["OMN+CoNN"] = _summary(5.5, sd=3.0, acc=0.4)
    rows = {c: (o, a) for _, c, o, a in claims(EXPERIMENTS["standard"], results)}
    assert rows["OMN+CoNN: the highest reward with the smallest SD (Fig. 5.6)"][1] == "no"
    assert rows["OMN opponent-action accuracy over 98% (5.5.3)"][1] == "no"


def test_area_claims_and_the_bound_goal():
    def area(reward, fraction):
        s = _summary(reward, rpe=reward / 10)
        s["fraction_of_bound"] = fraction
        return s

    results = {s: {"VNN": area(0.1 * s, 0.5), "OMN+CoNN": area(0.2 * s, 0.95 if s > 1 else 0.8)} for s in (1, 2, 3, 4)}
    rows = {c: (o, a) for _, c, o, a in claims(EXPERIMENTS["area"], results)}
    assert rows["Every network's reward falls as the reward area shrinks (Fig. 5.11)"][1] == "yes"
    assert rows["The opponent-modelling networks beat VNN at every size, most at size 1 (Fig. 5.11)"][1] == "yes"
    goal = [v for c, v in rows.items() if "90%" in c][0]
    assert goal == ("size 1: 80.0%, size 2: 95.0%, size 3: 95.0%, size 4: 95.0%", "no")


def test_better_and_more_claims_need_two_standard_errors():
    def bar(reward, episodes=10_000):
        return {**_summary(reward, sd=2.3), "episodes": episodes}

    standard = {None: {"VNN": bar(3.216), "IMNN": bar(2.921)}}
    # +0.03% (0.02 SE) is not "better"; +10% over 10,000 games each is
    double = {None: {"VNN": bar(3.217), "IMNN": bar(1.1 * 2.921)}}
    rows = {c: a for _, c, _, a in claims(EXPERIMENTS["double_blind"], double, standard)}
    assert rows["VNN: better than in Fig. 5.6 (Fig. 5.18)"] == "no"
    assert rows["IMNN: better than in Fig. 5.6 (Fig. 5.18)"] == "yes"
    # the same +10% over 100 games each is within noise (SE 0.33)
    few = {None: {"IMNN": bar(1.1 * 2.921, episodes=100)}}
    rows = {c: a for _, c, _, a in claims(EXPERIMENTS["double_blind"], few, {None: {"IMNN": bar(2.921, 100)}})}
    assert rows["IMNN: better than in Fig. 5.6 (Fig. 5.18)"] == "no"
    # energy: VNN's "more reward at 10 than at 15" by 0.01 is not more
    energy = {e: {"VNN": bar(r)} for e, r in ((10.0, 3.226), (15.0, 3.216), (20.0, 3.216))}
    rows = {c: a for _, c, _, a in claims(EXPERIMENTS["energy"], energy)}
    assert rows["VNN: more reward at energy 10 than at 15; similar at 20 (Fig. 5.8)"] == "no"
    energy[10.0]["VNN"] = bar(3.5)
    rows = {c: a for _, c, _, a in claims(EXPERIMENTS["energy"], energy)}
    assert rows["VNN: more reward at energy 10 than at 15; similar at 20 (Fig. 5.8)"] == "yes"


def test_area_claims_need_two_standard_errors():
    def bar(reward):
        return {**_summary(reward, sd=0.3), "episodes": 10_000, "fraction_of_bound": 0.5}

    # OMN+CoNN 0.001 above VNN (0.2 SE) at size 1 does not "beat" it; 0.05 (12 SE) at sizes 2-4 does
    results = {s: {"VNN": bar(0.1 * s), "OMN+CoNN": bar(0.1 * s + (0.001 if s == 1 else 0.05))} for s in (1, 2, 3, 4)}
    rows = {c: (o, a) for _, c, o, a in claims(EXPERIMENTS["area"], results)}
    beat = rows["The opponent-modelling networks beat VNN at every size, most at size 1 (Fig. 5.11)"]
    assert beat[0].startswith("size 1: no") and beat[1] == "no"
    # a fall of 0.002 between sizes (0.5 SE) is not a fall
    results = {s: {"VNN": bar(0.3 + 0.002 * s)} for s in (1, 2, 3, 4)}
    rows = {c: (o, a) for _, c, o, a in claims(EXPERIMENTS["area"], results)}
    assert rows["Every network's reward falls as the reward area shrinks (Fig. 5.11)"] == ("VNN: no", "no")


def test_claims_are_checked_on_the_faithful_and_the_strong_bars_apart():
    results = {None: {"VNN": _summary(5.0), "IMNN": _summary(4.0), "EMNN a=0.001": _summary(6.0),
                      "OMN+CoNN": _summary(7.0),
                      "VNN strong": _summary(7.0), "IMNN strong": _summary(7.1), "EMNN a=0.001 strong": _summary(7.2),
                      "OMN+CoNN strong": _summary(7.3)}}
    rows = claims(EXPERIMENTS["standard"], results)
    ranking = [(o, a) for _, c, o, a in rows if c.startswith("The ranking")]
    assert ranking == [("VNN 5.00 < IMNN 4.00 < EMNN a=0.001 6.00 < OMN+CoNN 7.00", "no")]
    strong = {c.removeprefix("[strong] "): (o, a) for _, c, o, a in rows if c.startswith("[strong] ")}
    assert strong["The ranking VNN < IMNN < EMNN < OMN+CoNN (Fig. 5.6: +9%, +17%, above +19%)"][1] == "yes"
    assert strong["OMN+CoNN: above +19% episode reward over VNN (Fig. 5.6)"] == ("+4.3%", "no")
    assert len(strong) == len(rows) - len(strong)  # every claim once per family


def test_the_ranking_needs_two_standard_errors_between_neighbours():
    def s(mean):
        return dict(_summary(mean, sd=1.0), episodes=100)  # SE of a difference: 0.141

    results = {None: {"VNN": s(5.0), "IMNN": s(5.5), "EMNN a=0.001": s(5.6), "OMN+CoNN": s(6.0)}}
    ranking = [a for _, c, o, a in claims(EXPERIMENTS["standard"], results) if c.startswith("The ranking")]
    assert ranking == ["no"]  # IMNN -> EMNN is 0.1 < 2 SE
    results[None].update({"EMNN a=0.001": s(5.8), "OMN+CoNN": s(6.2)})
    assert [a for _, c, o, a in claims(EXPERIMENTS["standard"], results) if c.startswith("The ranking")] == ["yes"]


def test_every_experiment_has_its_claims_as_records():
    assert set(CLAIMS) == set(EXPERIMENTS)
    for cset in CLAIMS.values():
        assert isinstance(cset, ClaimSet) and cset.claims
        for claim in cset.claims:
            assert isinstance(claim, Claim) and claim.test in TESTS and callable(claim.measure)
            assert claim.test == "holds" or claim.threshold is not None
    with pytest.raises(AttributeError):
        CLAIMS["standard"].claims[0].threshold = 0  # frozen


def test_a_claim_cites_its_figure_or_section():
    sources = {c.text: c.source for cset in CLAIMS.values() for c in cset.claims}
    assert sources["The ranking VNN < IMNN < EMNN < OMN+CoNN (Fig. 5.6: +9%, +17%, above +19%)"] == "5.6"
    assert sources["EMNN opponent-action accuracy about 75% (5.5.3)"] == "5.5.3"
    beyond = [t for t, src in sources.items() if not src]
    assert beyond == ["(beyond the thesis) OMN+CoNN >= 90% of the full-information bound at every size"]


def test_a_verdict_is_a_named_row():
    results = {None: {"VNN": _summary(5.0), "IMNN": _summary(5.45)}}
    v = claims(EXPERIMENTS["standard"], results)[0]
    assert isinstance(v, Verdict) and v == (v.source, v.claim, v.ours, v.agrees) and v.source == "5.6"
    assert v.claim.startswith("IMNN: about +9%") and v.ours == "+9.0%" and v.agrees == "yes"
    # a claim on a missing network cannot be judged
    assert claims(EXPERIMENTS["standard"], {None: {"VNN": _summary(5.0)}})[0].agrees == "n/a"


def test_about_the_same_is_within_five_percent():
    def bar(reward):
        return {**_summary(reward), "episodes": 100}

    standard = {None: {"EMNN a=0.001": bar(4.0), "OMN+CoNN": bar(4.0)}}
    double = {None: {"EMNN a=0.001": bar(3.84), "OMN+CoNN": bar(4.24)}}  # -4% and +6%
    rows = {c: (o, a) for _, c, o, a in claims(EXPERIMENTS["double_blind"], double, standard)}
    assert rows["EMNN: about the same as in Fig. 5.6 (Fig. 5.18)"] == ("-4.0% vs the standard set", "yes")
    assert rows["OMN+CoNN: about the same as in Fig. 5.6 (Fig. 5.18)"][1] == "no"
    assert rows["VNN: better than in Fig. 5.6 (Fig. 5.18)"] == ("n/a vs the standard set", "n/a")


def test_energy_claims_are_made_per_network_in_bar_order():
    def bar(reward, note=""):
        return {**_summary(reward), "episodes": 10_000, "note": note}

    results = {e: {"OMN+CoNN": bar(6.0, "" if e == 15.0 else "trained at energy 15"), "VNN": bar(5.0)}
               for e in (10.0, 15.0, 20.0)}
    rows = claims(EXPERIMENTS["energy"], results)
    assert [v.claim.split(":")[0] for v in rows] == ["VNN", "VNN", "OMN+CoNN", "OMN+CoNN"]
    assert rows[0].claim == "VNN: more reward at energy 10 than at 15; similar at 20 (Fig. 5.8)"
    assert rows[2].claim.startswith("OMN+CoNN: less reward at energy 10 than at 15")
    assert rows[2].ours.endswith("[played by the energy-15 network: not retrained as in the thesis]")
    assert not rows[0].ours.endswith("]")


def test_the_bound_claim_is_left_out_without_the_bound():
    results = {s: {"VNN": _summary(0.1 * s), "OMN+CoNN": _summary(0.2 * s)} for s in (1, 2)}
    assert not any("full-information bound" in v.claim for v in claims(EXPERIMENTS["area"], results))


def test_the_committed_figures_are_judged_and_written_again_identically():
    """Re-judging the stored bars of results/dcg/figure_*.json gives the stored claims and markdown (no games)."""
    import json
    import pathlib
    import re

    from jaxdc.dcg.analysis.experiment import ExperimentResults, group_key, stored_standard
    from jaxdc.dcg.analysis.report import figure_markdown

    folder = pathlib.Path(__file__).resolve().parents[3] / "results" / "dcg"
    if not (folder / "figure_standard.json").is_file():
        pytest.skip("no committed DCG figures")
    for name, exp in EXPERIMENTS.items():
        rec = json.loads((folder / f"figure_{name}.json").read_text())
        results = {g: rec["results"][group_key(g)] for g in exp.groups if group_key(g) in rec["results"]}
        bounds = {g: rec["bounds"][group_key(g)] for g in exp.groups if group_key(g) in rec["bounds"]}
        verdicts = claims(exp, results, stored_standard(str(folder)) if name == "double_blind" else None)
        assert [{"claim": v.claim, "ours": v.ours, "agrees": v.agrees} for v in verdicts] == rec["claims"]
        md = (folder / f"figure_{name}.md").read_text()
        images = re.findall(r"^!\[[^\]]*\]\(([^)]*)\)$", md, flags=re.M)
        assert figure_markdown(exp, ExperimentResults(results, bounds, {}), verdicts, rec["missing"], rec["command"],
                               images) == md
