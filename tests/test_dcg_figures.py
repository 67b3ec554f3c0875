"""jaxdc.dcg.figures: which networks each thesis figure uses, and the thesis' claims beside ours (no games played)."""

from __future__ import annotations

from jaxdc.dcg.figures import EXPERIMENTS, FIGURES, claims, label, missing, select
from jaxdc.dcg.opponents import DOUBLE_BLIND_STRATEGIES, STANDARD_STRATEGIES


def _meta(net, energy=15.0, steps=1_000_000, strategies=STANDARD_STRATEGIES, alpha=None):
    return {"net": net, "problem": "dcg", "energy": energy, "steps": steps, "strategies": list(strategies),
            "alpha": alpha}


def _summary(reward, sd=1.0, rpe=0.3, acc=None):
    return {"reward": {"mean": reward, "sd": sd}, "rpe": {"mean": rpe, "sd": 0.1}, "opponent_accuracy": acc,
            "per_strategy": {}, "note": ""}


def test_every_figure_pair_maps_to_one_experiment():
    assert FIGURES["5.6"] == FIGURES["5.7"] == "standard"
    assert FIGURES["5.11"] == FIGURES["5.12"] == "area"
    assert FIGURES["5.18"] == "double_blind" and EXPERIMENTS["double_blind"].strategies == DOUBLE_BLIND_STRATEGIES
    assert label(_meta("emnn", alpha=0.0001)) == "EMNN a=0.0001" and label(_meta("omn_conn")) == "OMN+CoNN"


def test_select_orders_networks_and_prefers_retrained_ones():
    pool = {"omn_conn": _meta("omn_conn"), "vnn": _meta("vnn"), "emnn": _meta("emnn", alpha=0.001),
            "emnn4": _meta("emnn", alpha=0.0001), "vnn_e10": _meta("vnn", energy=10.0),
            "vnn_5m": _meta("vnn", steps=5_000_000),
            "a_vnn_area2": dict(_meta("vnn", steps=10_000_000), reward_area=2)}  # sorts first; never a thesis bar
    standard = select(pool, EXPERIMENTS["standard"], None)
    assert [e.label for e in standard] == ["VNN", "EMNN a=0.001", "EMNN a=0.0001", "OMN+CoNN"]
    assert [e.name for e in standard][0] == "vnn"  # not the 5M or energy-10 network
    at10 = {e.label: e for e in select(pool, EXPERIMENTS["energy"], 10.0)}
    assert at10["VNN"].name == "vnn_e10" and at10["VNN"].note == "" and at10["VNN"].energy == 10.0
    assert at10["OMN+CoNN"].name == "omn_conn" and at10["OMN+CoNN"].note == "trained at energy 15"
    area = select(pool, EXPERIMENTS["area"], 2)
    assert all(e.reward_area == 2 for e in area) and "a_vnn_area2" not in {e.name for e in area}
    assert [e.name for e in select(pool, EXPERIMENTS["standard_5m"], None)] == ["vnn_5m"]
    blind = select(pool, EXPERIMENTS["double_blind"], None)
    assert all(e.strategies == DOUBLE_BLIND_STRATEGIES and "not retrained" in e.note for e in blind)
    gone = missing(pool, EXPERIMENTS["standard"])
    assert gone == ["IMNN trained in the standard setting"]


def test_standard_claims_on_a_hand_example():
    results = {None: {"VNN": _summary(5.0, sd=2.0, rpe=0.40), "IMNN": _summary(5.45, rpe=0.30),
                      "EMNN a=0.001": _summary(5.85, rpe=0.35, acc=0.74),
                      "EMNN a=0.0001": _summary(5.5, rpe=0.45, acc=0.5),
                      "OMN+CoNN": _summary(6.0, sd=0.5, rpe=0.33, acc=0.99)}}
    rows = {c: (o, a) for c, o, a in claims(EXPERIMENTS["standard"], results)}
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
    rows = {c: (o, a) for c, o, a in claims(EXPERIMENTS["standard"], results)}
    assert rows["OMN+CoNN: the highest reward with the smallest SD (Fig. 5.6)"][1] == "no"
    assert rows["OMN opponent-action accuracy over 98% (5.5.3)"][1] == "no"


def test_area_claims_and_the_bound_goal():
    def area(reward, fraction):
        s = _summary(reward, rpe=reward / 10)
        s["fraction_of_bound"] = fraction
        return s

    results = {s: {"VNN": area(0.1 * s, 0.5), "OMN+CoNN": area(0.2 * s, 0.95 if s > 1 else 0.8)} for s in (1, 2, 3, 4)}
    rows = {c: (o, a) for c, o, a in claims(EXPERIMENTS["area"], results)}
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
    rows = {c: a for c, _, a in claims(EXPERIMENTS["double_blind"], double, standard)}
    assert rows["VNN: better than in Fig. 5.6 (Fig. 5.18)"] == "no"
    assert rows["IMNN: better than in Fig. 5.6 (Fig. 5.18)"] == "yes"
    # the same +10% over 100 games each is within noise (SE 0.33)
    few = {None: {"IMNN": bar(1.1 * 2.921, episodes=100)}}
    rows = {c: a for c, _, a in claims(EXPERIMENTS["double_blind"], few, {None: {"IMNN": bar(2.921, 100)}})}
    assert rows["IMNN: better than in Fig. 5.6 (Fig. 5.18)"] == "no"
    # energy: VNN's "more reward at 10 than at 15" by 0.01 is not more
    energy = {e: {"VNN": bar(r)} for e, r in ((10.0, 3.226), (15.0, 3.216), (20.0, 3.216))}
    rows = {c: a for c, _, a in claims(EXPERIMENTS["energy"], energy)}
    assert rows["VNN: more reward at energy 10 than at 15; similar at 20 (Fig. 5.8)"] == "no"
    energy[10.0]["VNN"] = bar(3.5)
    rows = {c: a for c, _, a in claims(EXPERIMENTS["energy"], energy)}
    assert rows["VNN: more reward at energy 10 than at 15; similar at 20 (Fig. 5.8)"] == "yes"


def test_area_claims_need_two_standard_errors():
    def bar(reward):
        return {**_summary(reward, sd=0.3), "episodes": 10_000, "fraction_of_bound": 0.5}

    # OMN+CoNN 0.001 above VNN (0.2 SE) at size 1 does not "beat" it; 0.05 (12 SE) at sizes 2-4 does
    results = {s: {"VNN": bar(0.1 * s), "OMN+CoNN": bar(0.1 * s + (0.001 if s == 1 else 0.05))} for s in (1, 2, 3, 4)}
    rows = {c: (o, a) for c, o, a in claims(EXPERIMENTS["area"], results)}
    beat = rows["The opponent-modelling networks beat VNN at every size, most at size 1 (Fig. 5.11)"]
    assert beat[0].startswith("size 1: no") and beat[1] == "no"
    # a fall of 0.002 between sizes (0.5 SE) is not a fall
    results = {s: {"VNN": bar(0.3 + 0.002 * s)} for s in (1, 2, 3, 4)}
    rows = {c: (o, a) for c, o, a in claims(EXPERIMENTS["area"], results)}
    assert rows["Every network's reward falls as the reward area shrinks (Fig. 5.11)"] == ("VNN: no", "no")


def _strong(net, steps=3_000_000, **kw):
    meta = _meta(net, steps=steps, **kw)
    meta["algorithm"] = {"clip_eps": 0.2, "total_steps": steps}
    return meta


def test_strong_networks_join_figs_5_6_5_16_and_5_11_only():
    pool = {"vnn": _meta("vnn"), "vnn_5m": _meta("vnn", steps=5_000_000), "vnn_strong": _strong("vnn"),
            "vnn_strong_1m": _strong("vnn", steps=1_000_000), "emnn_strong": _strong("emnn", alpha=0.001),
            "omn_conn_strong": _strong("omn_conn")}
    assert label(pool["vnn_strong"]) == "VNN strong" and label(pool["emnn_strong"]) == "EMNN a=0.001 strong"
    standard = select(pool, EXPERIMENTS["standard"], None)
    assert [(e.label, e.name) for e in standard] == [("VNN", "vnn"), ("VNN strong", "vnn_strong_1m")]
    five = select(pool, EXPERIMENTS["standard_5m"], None)
    assert [e.name for e in five] == ["vnn_5m", "vnn_strong", "emnn_strong", "omn_conn_strong"]
    assert {e.name for e in select(pool, EXPERIMENTS["area"], 1)} == {"vnn", "vnn_strong", "emnn_strong",
                                                                      "omn_conn_strong"}
    for name, group in (("energy", 10.0), ("double_blind", None)):
        assert not any(e.label.endswith("strong") for e in select(pool, EXPERIMENTS[name], group))
    # a strong network never stands in for a missing faithful one
    assert "OMN+CoNN trained for 5M steps" in missing(pool, EXPERIMENTS["standard_5m"])


def test_claims_are_checked_on_the_faithful_and_the_strong_bars_apart():
    results = {None: {"VNN": _summary(5.0), "IMNN": _summary(4.0), "EMNN a=0.001": _summary(6.0),
                      "OMN+CoNN": _summary(7.0),
                      "VNN strong": _summary(7.0), "IMNN strong": _summary(7.1), "EMNN a=0.001 strong": _summary(7.2),
                      "OMN+CoNN strong": _summary(7.3)}}
    rows = claims(EXPERIMENTS["standard"], results)
    ranking = [(o, a) for c, o, a in rows if c.startswith("The ranking")]
    assert ranking == [("VNN 5.00 < IMNN 4.00 < EMNN a=0.001 6.00 < OMN+CoNN 7.00", "no")]
    strong = {c.removeprefix("[strong] "): (o, a) for c, o, a in rows if c.startswith("[strong] ")}
    assert strong["The ranking VNN < IMNN < EMNN < OMN+CoNN (Fig. 5.6: +9%, +17%, above +19%)"][1] == "yes"
    assert strong["OMN+CoNN: above +19% episode reward over VNN (Fig. 5.6)"] == ("+4.3%", "no")
    assert len(strong) == len(rows) - len(strong)  # every claim once per family


def test_the_ranking_needs_two_standard_errors_between_neighbours():
    def s(mean):
        return dict(_summary(mean, sd=1.0), episodes=100)  # SE of a difference: 0.141

    results = {None: {"VNN": s(5.0), "IMNN": s(5.5), "EMNN a=0.001": s(5.6), "OMN+CoNN": s(6.0)}}
    ranking = [a for c, o, a in claims(EXPERIMENTS["standard"], results) if c.startswith("The ranking")]
    assert ranking == ["no"]  # IMNN -> EMNN is 0.1 < 2 SE
    results[None].update({"EMNN a=0.001": s(5.8), "OMN+CoNN": s(6.2)})
    assert [a for c, o, a in claims(EXPERIMENTS["standard"], results) if c.startswith("The ranking")] == ["yes"]
