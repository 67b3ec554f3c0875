"""jaxdc.report.scorecard: the scorecard rows read from stored results (DCP Δ/SE verdicts with the best learner,
DCG claim counts, the exact yardsticks) and a damaged file named."""

import json
import re

import pytest

from jaxdc.report.scorecard import anchor, delta_se, scorecard, verdict


def _summary(mean, sd=1.0, episodes=10000):
    return {"reward": {"mean": mean, "sd": sd}, "energy": {"mean": 1.0, "sd": 1.0}, "rpe": {"mean": 0.1, "sd": 0.1},
            "episodes": episodes}


def _table(tmp_path, **over):
    d = tmp_path / "dcp"
    d.mkdir(parents=True, exist_ok=True)
    payload = {"table": "4.3", "caption": "High risk, total reward 30, energy 8/16",
               "command": "python -m eval.dcp --table 4.3 --episodes 10000",
               "thesis": {"safe_reward": [11.55, 5.0, 0, 0, 0, 0], "safe_both": [12.0, 5.0, 0, 0, 0, 0],
                          "enn": [13.16, 7.0, 0, 0, 0, 0]},
               "ours": {"safe_reward": _summary(11.56, 5.0), "safe_both": _summary(11.0, 5.0),
                        "enn": _summary(12.88, 7.0), "enn best": _summary(14.80, 7.0)},
               "learned": {"net": "enn", "row": "enn", "source": "enn"},
               "best": {"row": "enn best", "thesis_row": "enn", "checkpoint": "enn_long", "source": "enn_long",
                        "differs": "16M steps", "trained": {}}}
    payload.update(over)
    (d / f"table_{payload['table']}.json").write_text(json.dumps(payload))
    return payload


def test_delta_se_and_verdicts():
    assert delta_se(12.0, 11.0, 5.0, 10000) == pytest.approx(20.0)
    assert delta_se(12.0, None, 5.0, 10000) is None and delta_se(1.0, 1.0, 0.0, 10) is None
    assert [verdict(d) for d in (2.9, -3.0, 3.1, -7.0, None)] == ["reproduced", "reproduced", "above", "below", "—"]


def test_anchor_is_githubs():
    assert anchor("Table 4.3: High risk, total reward 30, energy 8/16") \
        == "table-43-high-risk-total-reward-30-energy-816"


def test_dcp_rows_give_navigators_faithful_and_best(tmp_path):
    _table(tmp_path)
    card = scorecard(str(tmp_path))
    # navigators: safe_reward +0.2 SE, safe_both -20 SE -> one of two off
    assert ("| DCP Table 4.3 | 2 navigators, reward | 1 of 2 within 3 SE (largest -20.0 SE, -8.3%) | — "
            "| 1 of 2 off |") in card
    # learned: (12.88 - 13.16) / (7 / 100) = -4.0 SE; best (14.80 - 13.16) / 0.07 = +23.4 SE
    assert ("| enn reward 13.16 | 12.88 (-4.0 SE) | 14.80 (+23.4 SE): `enn_long`, 16M steps "
            "| faithful: below; best: above |") in card
    assert "(#table-43-high-risk-total-reward-30-energy-816) `python -m eval.dcp --table 4.3 --episodes 10000`" in card


def test_dcp_table_without_best_or_learner(tmp_path):
    _table(tmp_path, best=None)
    assert "| 12.88 (-4.0 SE) | — | faithful: below |" in scorecard(str(tmp_path))
    _table(tmp_path, table="4.1", caption="tours", learned=None, best=None,
           thesis={"ng": [5.0, 1.0, None, None, None, None]}, ours={"ng": _summary(5.01)})
    assert ("| DCP Table 4.1 | 1 tour heuristics, reward | 1 of 1 within 3 SE (largest +1.0 SE, +0.2%) | — "
            "| reproduced |") in scorecard(str(tmp_path))


def _figure(tmp_path, claims, name="standard"):
    d = tmp_path / "dcg"
    d.mkdir(parents=True, exist_ok=True)
    rec = {"experiment": name, "figures": ["5.6", "5.7"], "caption": "standard setting",
           "command": "python -m eval.dcg figure 5.6", "results": {"all": {
               "VNN": _summary(3.0), "OMN+CoNN strong": _summary(7.0)}},
           "bounds": {"all": {"total": 8.0, "se": 0.05, "episodes": 2000}},
           "claims": [{"claim": c, "ours": "x", "agrees": a} for c, a in claims]}
    (d / f"figure_{name}.json").write_text(json.dumps(rec))
    (d / f"figure_{name}.md").write_text("### Figs. 5.6 and 5.7: standard setting\n")


def test_dcg_rows_count_agreeing_claims_faithful_and_strong(tmp_path):
    _figure(tmp_path, [("a (Fig. 5.6)", "yes"), ("b (Fig. 5.6)", "no"), ("c (Fig. 5.6)", "n/a"),
                       ("[strong] a (Fig. 5.6)", "yes"), ("[strong] b (Fig. 5.6)", "yes")])
    card = scorecard(str(tmp_path))
    assert "| DCG Figs. 5.6, 5.7 | 2 claims of the text (standard setting) | 1 of 2 agree | 2 of 2 agree (strong " \
           "networks) | faithful: partly; strong: 2/2 | [§](#figs-56-and-57-standard-setting)" in card
    assert "| 3.00 = 37.5% (VNN) | 7.00 = 87.5% (OMN+CoNN strong) | share of the bound |" in card


def test_single_item_yardstick_uses_the_exact_optimum(tmp_path):
    _table(tmp_path, table="4.8", caption="one item", thesis={"enn": [0.83, 0.37, 0, 0, 0, 0]},
           ours={"enn": _summary(0.30), "enn best": _summary(0.90), "optimal": dict(_summary(0.921),
                                                                                 expected_optimum=0.92)})
    card = scorecard(str(tmp_path))
    assert "| DCP Table 4.8 setting | exact optimum 0.920 (value iteration; not in the thesis); goal 97% | 0.300 = " \
           "32.6% | 0.900 = 97.8%: `enn_long` | goal met |" in card


def test_a_damaged_results_file_is_named(tmp_path):
    d = tmp_path / "dcg"
    d.mkdir()
    (d / "figure_x.json").write_text(json.dumps({"experiment": "x"}))
    with pytest.raises(ValueError, match=r"figure_x.json: not a file written by python -m eval.dcg figure"):
        scorecard(str(tmp_path))
    (d / "figure_x.json").unlink()
    _table(tmp_path, ours={"enn": {"reward": "many"}})
    with pytest.raises(ValueError, match=r"table_4.3.json: ours\.enn\.reward must be a JSON object, got 'many'; "
                                         r"rerun python -m eval.dcp --table"):
        scorecard(str(tmp_path))


# -- hostile input (issue 31): a damaged stored result is refused naming the file and the key, never dropped -------
@pytest.mark.parametrize("edit, key", [
    (lambda p: p["ours"]["safe_reward"]["reward"].update(mean="abc"),
     "ours.safe_reward.reward.mean must be a number or null, got 'abc'"),
    (lambda p: p["ours"]["safe_both"].pop("episodes"), "ours.safe_both.episodes is missing"),
    (lambda p: p["ours"]["safe_reward"].update(episodes=0), "ours.safe_reward.episodes must be at least 1, got 0"),
    (lambda p: p["thesis"]["enn"].pop(), "thesis.enn must hold 6 values"),
    (lambda p: p["thesis"]["enn"].__setitem__(0, "13"), r"thesis.enn\[0\] must be a number or null, got '13'"),
    (lambda p: p["best"].update(row="nope"), "best.row 'nope' is not a row of ours"),
    (lambda p: p.update(table="4.4"), "table '4.4' is not the table of the file's name"),
    (lambda p: p["ours"]["enn"]["rpe"].update(sd=-1), "ours.enn.rpe.sd must be at least 0"),
])
def test_a_damaged_dcp_table_is_refused_naming_the_file_and_key(tmp_path, edit, key):
    payload = _table(tmp_path)
    edit(payload)
    (tmp_path / "dcp" / "table_4.3.json").write_text(json.dumps(payload))
    with pytest.raises(ValueError, match=rf"dcp/table_4\.3\.json: {key}"):
        scorecard(str(tmp_path))


def test_an_undefined_navigator_is_counted_not_dropped(tmp_path):
    payload = _table(tmp_path)
    payload["ours"]["safe_both"]["reward"]["mean"] = None  # undefined (null) is shown, not refused
    (tmp_path / "dcp" / "table_4.3.json").write_text(json.dumps(payload))
    assert "1 of 1 within 3 SE (largest +0.2 SE, +0.1%); 1 more without a Δ/SE" in scorecard(str(tmp_path))


@pytest.mark.parametrize("edit, key", [
    (lambda r: r["results"]["all"]["VNN"].pop("reward"), "results.all.VNN.reward is missing"),
    (lambda r: r["results"]["all"]["VNN"]["reward"].update(mean="abc"),
     "results.all.VNN.reward.mean must be a number or null, got 'abc'"),
    (lambda r: r.update(figures=[]), "figures must name at least one figure"),
    (lambda r: r["claims"][0].pop("agrees"), r"claims\[0\].agrees is missing"),
    (lambda r: r["bounds"]["all"].pop("se"), "bounds.all.se is missing"),
])
def test_a_damaged_dcg_figure_is_named_by_its_real_path_and_key(tmp_path, edit, key):
    _figure(tmp_path, [("a (Fig. 5.6)", "yes")], name="standard_5m")
    path = tmp_path / "dcg" / "figure_standard_5m.json"
    rec = json.loads(path.read_text())
    edit(rec)
    path.write_text(json.dumps(rec))
    with pytest.raises(ValueError) as e:
        scorecard(str(tmp_path))
    assert re.match(rf"{re.escape(str(path))}: {key}", str(e.value)), str(e.value)
    assert "Error(" not in str(e.value)  # no exception repr


def test_damaged_drp_results_are_refused_naming_the_file_and_key(tmp_path):
    d = tmp_path / "drp"
    d.mkdir()
    (d / "experiment_r5_g2_n5_centre_s0.json").write_text(json.dumps(
        {"config": {"rewards": "5", "graphs": 2, "nodes": 5, "alphas": [0], "base": "centre", "seed": 0},
         "wall_seconds": 1.0, "rows": [{"clustering": "nc", "alpha": 0, "mean": 1.0, "sd": 0.0}]}))
    with pytest.raises(ValueError, match=r"experiment_r5_g2_n5_centre_s0\.json: rows\[0\]\.builder is missing"):
        scorecard(str(tmp_path))
    (d / "experiment_r5_g2_n5_centre_s0.json").unlink()
    _table(tmp_path)
    (d / "gaps_n8_g2.json").write_text(json.dumps(
        {"config": {"graphs": 2, "nodes": 8, "base": "centre"},
         "rows": [{"clustering": "nc", "builder": "gi", "mean_ratio": "high", "graphs": 2}]}))
    with pytest.raises(ValueError, match=r"gaps_n8_g2\.json: rows\[0\]\.mean_ratio must be a number or null"):
        scorecard(str(tmp_path))


def test_a_figure_heading_that_is_not_text_is_named(tmp_path):
    _figure(tmp_path, [("a (Fig. 5.6)", "yes")])
    (tmp_path / "dcg" / "figure_standard.md").write_bytes(b"\x80\x81 not text")
    with pytest.raises(ValueError, match=r"figure_standard\.md: not a UTF-8 text file"):
        scorecard(str(tmp_path))
