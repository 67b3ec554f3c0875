"""jaxdc.dcg.analysis: the evaluation cache, the network pool, the reports of a figure, and the bar charts
(jaxdc.viewer.bars); no games played."""

from __future__ import annotations

import csv
import io
import json
import os

import pytest

from jaxdc.core.claims import Verdict
from jaxdc.dcg.analysis.cache import EvaluationCache
from jaxdc.dcg.analysis.experiment import ExperimentResults, ExperimentSettings, group_key, network_pool
from jaxdc.dcg.analysis.figures import EXPERIMENTS
from jaxdc.dcg.analysis.report import (
    figure_csv,
    figure_markdown,
    figure_payload,
    optimum_name,
    optimum_payload,
    report,
    result_name,
)
from jaxdc.viewer.bars import save_bar_chart, save_strategy_chart

PNG = b"\x89PNG\r\n\x1a\n"


def _stat(mean, sd=0.5):
    return {"mean": mean, "sd": sd}


def _bar(reward, strategies=("patrol", "restricted", "with_fog")):
    per = {s: {"episodes": 10, "reward": _stat(reward), "rpe": _stat(0.3), "energy": _stat(5.0),
               "steps": _stat(20.0), "opponent_accuracy": None} for s in strategies}
    return {"episodes": 30, "reward": _stat(reward), "rpe": _stat(0.3), "energy": _stat(5.0), "steps": _stat(20.0),
            "opponent_accuracy": None, "per_strategy": per, "file": "vnn", "note": ""}


def test_cache_keys_on_file_bytes_metadata_and_settings(tmp_path):
    blob = tmp_path / "net.msgpack"
    blob.write_bytes(b"params")
    (tmp_path / "net.json").write_text("{}")
    cache = EvaluationCache(str(tmp_path / "cache"))
    settings = {"episodes": 10, "seed": 0, "strategies": ("patrol",)}
    assert cache.load(str(blob), settings) is None
    path = cache.store(str(blob), settings, {"reward": 1.0})
    assert os.path.dirname(path) == str(tmp_path / "cache") and len(os.path.basename(path)) == 24 + len(".json")
    assert cache.load(str(blob), settings) == {"reward": 1.0}
    assert cache.load(str(blob), dict(settings, seed=1)) is None
    (tmp_path / "net.json").write_text('{"steps": 1}')  # other metadata: another file
    assert cache.load(str(blob), settings) is None
    bound = cache.store(None, settings, {"total": 2.0})
    assert os.path.basename(bound).startswith("bound_") and cache.load(None, settings) == {"total": 2.0}
    assert EvaluationCache(cache.folder, reuse=False).load(None, settings) is None
    with pytest.raises(AttributeError):
        cache.folder = "elsewhere"  # frozen


def test_cache_files_record_provenance_that_load_leaves_out(tmp_path):
    import json

    import jaxdc

    cache = EvaluationCache(str(tmp_path / "cache"))
    settings = {"episodes": 10, "seed": 0}
    path = cache.store(None, settings, {"total": 2.0})
    with open(path) as f:
        stored = json.load(f)
    assert stored["total"] == 2.0 and stored["provenance"]["jaxdc_version"] == jaxdc.__version__
    assert set(stored["provenance"]) >= {"jax_version", "git", "device", "command"}
    assert cache.load(None, settings) == {"total": 2.0}  # a result read back is the one stored
    with pytest.raises(ValueError, match="'provenance'"):
        cache.store(None, settings, {"total": 2.0, "provenance": {}})


def test_network_pool_reads_dcg_metadata_only(tmp_path):
    for name, problem in (("a", "dcg"), ("b", "dcp")):
        (tmp_path / f"{name}.msgpack").write_bytes(b"")
        (tmp_path / f"{name}.json").write_text(json.dumps({"problem": problem, "net": "vnn"}))
    pool, folder = network_pool(str(tmp_path))
    assert list(pool) == ["a"] and folder == str(tmp_path)
    with pytest.raises(ValueError, match="no such folder"):
        network_pool(str(tmp_path / "nothing"))
    shipped, _ = network_pool(None)
    assert "omn_conn" in shipped and all(m["problem"] == "dcg" for m in shipped.values())


@pytest.mark.parametrize("key, value, words", [
    ("energy_range", "8-25", "energy_range must be a pair"),
    ("steps", "many", "steps='many' must be an int >= 1"),
    ("init_from", 7, "'init_from'"),
    ("collectors", 0, "'collectors'"),
])
def test_a_pool_file_with_a_bad_setting_is_refused_naming_the_file_and_key(tmp_path, key, value, words):
    """The figures read the pool's settings (energy ranges, steps, warm starts) before any game: a bad one is the
    loader's ValueError naming the file and the key, not a TypeError from inside the selection."""
    (tmp_path / "g.msgpack").write_bytes(b"")
    (tmp_path / "g.json").write_text(json.dumps({"problem": "dcg", "net": "omn_conn", key: value}))
    with pytest.raises(ValueError, match="g.msgpack") as e:
        network_pool(str(tmp_path))
    assert words in str(e.value) and key in str(e.value)


def test_settings_and_group_keys():
    s = ExperimentSettings()
    assert (s.episodes, s.seed, s.greedy, s.bound, s.bound_episodes) == (10_000, 0, False, True, 2000)
    assert [group_key(g) for g in (None, 10.0, 2)] == ["all", "10", "2"]


def test_one_evaluation_report_and_file_name():
    r = dict(_bar(5.0), net="emnn", alpha=0.001, seed=3, greedy=True, outcomes={"caught": 2, "energy": 1},
             setting={"strategies": ["patrol", "restricted", "with_fog"], "energy": 15.0, "reward_area": 2})
    assert result_name(r) == "eval_emnn_a0.001_e15_standard_area2_greedy_s3.json"
    lines = report(r).splitlines()
    assert lines[0].startswith("all (30 games)") and "reward 5.000 ± 0.500" in lines[0]
    assert lines[1] == "outcomes: caught 2, energy 1" and len(lines) == 5


def test_figure_tables_and_payload():
    exp = EXPERIMENTS["standard"]
    data = ExperimentResults({None: {"VNN": _bar(5.0)}}, {None: {"total": 8.0}}, {})
    data.results[None]["VNN"]["fraction_of_bound"] = 0.625
    verdicts = [Verdict("5.6", "a claim", "ours", "yes")]
    md = figure_markdown(exp, data, verdicts, ["IMNN trained in the standard setting"], "cmd", ["img/x.png"])
    assert "| VNN | 5.000 ± 0.500 | 0.3000 ± 0.5000 | — | 8.0000 / 62.5% | 5.000 | 5.000 | 5.000 |  |" in md
    assert "| a claim | ours | yes |" in md and md.endswith("IMNN trained in the standard setting.\n")
    rows = list(csv.reader(io.StringIO(figure_csv(data.results))))
    assert rows[0][0] == "group" and [r[2] for r in rows[1:]] == ["all", "patrol", "restricted", "with_fog"]
    payload = figure_payload(exp, data, verdicts, [], command="cmd", episodes=30, seed=0, greedy=False)
    assert payload["claims"] == [{"claim": "a claim", "ours": "ours", "agrees": "yes"}]
    assert list(payload["results"]) == ["all"] and payload["bounds"] == {"all": {"total": 8.0}}


def test_optimum_record_and_name():
    import numpy as np

    res = {"mean": 1.5, "rewards": np.array([1.0, 2.0, 2.0])}
    out = optimum_payload(res, "DCG()", energy=15.0, max_steps=100, chase_tie="straight", seed=0, command="c")
    assert out["optimum"] == {"mean": 1.5} and "rewards" in res  # the caller's result is left as it was
    assert out["reward_histogram"] == {"1": 1, "2": 2}
    name = optimum_name(out, 3)
    assert name.startswith("optimum_") and name != optimum_name(out, 4)


def test_bar_charts_are_pngs_without_pyplot_state(tmp_path):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    results = {g: {"VNN": _bar(5.0), "OMN+CoNN strong": _bar(6.0)} for g in (10.0, 15.0)}
    for col in ("reward", "rpe"):
        path = save_bar_chart(str(tmp_path / f"{col}.png"), results, (10.0, 15.0), col, "t",
                              {10.0: {"total": 8.0}}, ["energy 10", "energy 15"])
        assert open(path, "rb").read(8) == PNG
    one = save_bar_chart(str(tmp_path / "one.png"), {None: results[10.0]}, (None,), "reward", "t", {None: {"total": 8}})
    assert open(one, "rb").read(8) == PNG
    assert save_strategy_chart(str(tmp_path / "s.png"), results[10.0], "t") == str(tmp_path / "s.png")
    assert save_strategy_chart(str(tmp_path / "none.png"), {}, "t") is None and not (tmp_path / "none.png").exists()
    assert plt.get_fignums() == before  # no pyplot figure leaked


def test_the_report_of_a_reward_area_game_gives_each_strategy_its_own_bound():
    r = dict(_bar(0.5), outcomes={"caught": 1}, bound={"total": 0.8, "per_strategy": {"patrol": 1.0,
                                                                                       "restricted": 0.5}},
             fraction_of_bound=0.625)
    r["per_strategy"]["patrol"]["fraction_of_bound"] = 0.5
    r["per_strategy"]["restricted"]["fraction_of_bound"] = 1.0
    r["per_strategy"]["with_fog"]["fraction_of_bound"] = None
    lines = report(r).splitlines()
    assert lines[0].endswith("62.5% of the bound 0.8000")
    assert lines[2].startswith("patrol") and lines[2].endswith("50.0% of the bound 1.0000")
    assert lines[3].endswith("100.0% of the bound 0.5000") and "bound" not in lines[4]
