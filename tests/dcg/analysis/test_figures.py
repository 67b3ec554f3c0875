"""jaxdc.dcg.analysis.figures: which networks each thesis figure uses (no games played)."""

from __future__ import annotations

from jaxdc.dcg.analysis.figures import (
    EXPERIMENTS,
    FIGURES,
    GENERAL,
    STRONG,
    family,
    label,
    missing,
    select,
    total_steps,
)
from jaxdc.dcg.opponents import DOUBLE_BLIND_STRATEGIES, STANDARD_STRATEGIES


def _meta(net, energy=15.0, steps=1_000_000, strategies=STANDARD_STRATEGIES, alpha=None):
    return {"net": net, "problem": "dcg", "energy": energy, "steps": steps, "strategies": list(strategies),
            "alpha": alpha}


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


def test_family_splits_faithful_strong_and_general_bars():
    results = {None: {"VNN": 1, "VNN strong": 2, "OMN+CoNN strong": 3, "OMN+CoNN general": 4}}
    assert family(results) == {None: {"VNN": 1}}
    assert family(results, STRONG) == {None: {"VNN": 2, "OMN+CoNN": 3}}
    assert family(results, GENERAL) == {None: {"OMN+CoNN": 4}}


def test_the_per_strategy_chart_joins_the_one_group_experiments():
    assert {n for n, e in EXPERIMENTS.items() if e.per_strategy_chart} == {"standard", "standard_5m", "double_blind"}


def test_a_network_trained_over_a_range_of_energies_is_no_thesis_bar():
    """A network over energies 8..25 (beyond the thesis) records energy 15 too; it never stands for the thesis'
    energy-15 (or any) network."""
    pool = {"a_omn_general": dict(_meta("omn_conn"), energy_range=[8.0, 25.0], observation="general"),
            "omn_conn": _meta("omn_conn")}
    for exp, group in ((EXPERIMENTS["standard"], None), (EXPERIMENTS["energy"], 15.0)):
        assert [e.name for e in select(pool, exp, group) if e.label == "OMN+CoNN"] == ["omn_conn"]


def test_the_general_network_trained_longest_joins_the_energy_bars_only():
    """The energy experiment (Figs. 5.8-5.9) gains one general bar per network kind: of the networks whose energy
    range holds 10, 15 and 20, the one trained the most steps in all, a warm start counting its source's steps.
    A range that misses an energy, a reward area, a team or another strategy set does not qualify, and no other
    experiment shows general bars."""
    strong = {"algorithm": {"clip_eps": 0.2}}
    general = dict(_meta("omn_conn", steps=5_000_000), energy_range=[8.0, 25.0], observation="general", **strong)
    pool = {"omn_conn": _meta("omn_conn"),
            "omn_conn_general": general,
            "omn_conn_general_long": dict(general, steps=4_000_000, init_from="omn_conn_general"),  # 9M in all
            "omn_conn_general_big": dict(general, steps=6_000_000),
            "omn_conn_low": dict(general, steps=50_000_000, energy_range=[8.0, 12.0]),  # misses 15 and 20
            "omn_conn_area": dict(general, steps=50_000_000, reward_area=2),
            "omn_conn_team": dict(general, steps=50_000_000, collectors=2),
            "omn_conn_db": dict(general, steps=50_000_000, strategies=list(DOUBLE_BLIND_STRATEGIES))}
    assert total_steps(pool, "omn_conn_general_long") == 9_000_000 and total_steps(pool, "missing") == 0
    for e in (10.0, 15.0, 20.0):
        bars = {b.label: b for b in select(pool, EXPERIMENTS["energy"], e)}
        assert bars["OMN+CoNN general"].name == "omn_conn_general_long" and bars["OMN+CoNN general"].energy == e
        assert "8-25" in bars["OMN+CoNN general"].note
        assert [lb for lb in bars if lb.endswith(GENERAL)] == ["OMN+CoNN general"]
    for name, exp in EXPERIMENTS.items():
        if name != "energy":
            assert not any(b.label.endswith(GENERAL) for g in exp.groups for b in select(pool, exp, g)), name
    assert not any(b.label.endswith(STRONG) for b in select(pool, EXPERIMENTS["energy"], 10.0))
    # a network trained under an action mask plays under it (as trained), and its bar says so
    pool["omn_conn_general_masked"] = dict(general, steps=5_000_000, init_from="omn_conn_general_long",
                                           mask="reach_base_or_item")
    bar = {b.label: b for b in select(pool, EXPERIMENTS["energy"], 10.0)}["OMN+CoNN general"]
    assert bar.name == "omn_conn_general_masked" and bar.note.endswith("under the action mask reach_base_or_item")
