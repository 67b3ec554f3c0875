"""Hostile input for the DCG's stored results: a damaged cached evaluation, cached bound or figure file is refused
with one line naming the file and the key, never shown as a bar (issue 31)."""

from __future__ import annotations

import copy
import json
import os

import pytest

from jaxdc.core.record_fields import Fields
from jaxdc.dcg.analysis.cache import EvaluationCache
from jaxdc.dcg.analysis.experiment import stored_standard
from jaxdc.dcg.analysis.records import check_bound, check_evaluation, check_figure


def _stat(mean, sd=0.5):
    return {"mean": mean, "sd": sd}


def _evaluation():
    per = {s: {"episodes": 10, "reward": _stat(1.0), "rpe": _stat(0.3), "energy": _stat(5.0), "steps": _stat(20.0),
               "outcomes": {"caught": 1}, "opponent_accuracy": None} for s in ("patrol", "with_fog")}
    return {"reward": _stat(1.0), "energy": _stat(5.0), "rpe": _stat(0.3), "episodes": 20,
            "outcomes": {"caught": 2, "cleared": 18}, "steps": _stat(20.0), "opponent_accuracy": None,
            "per_strategy": per, "seconds": 0.5, "net": "vnn", "alpha": None, "source": "vnn.msgpack",
            "setting": {"grid_size": 5, "energy": 15.0, "strategies": ["patrol", "with_fog"], "reward_area": None},
            "seed": 0, "greedy": False}


def _bound():
    return {"total": 8.7, "se": 0.05, "episodes": 2000, "per_strategy": {"patrol": 9.9}, "game": {}}


def _figure():
    bar = dict(_evaluation(), file="vnn_5m", note="", fraction_of_bound=0.5)
    return {"experiment": "standard", "figures": ["5.6"], "caption": "c", "command": "python -m eval.dcg figure 5.6",
            "results": {"all": {"VNN": bar, "CNN": copy.deepcopy(bar), "EMNN": copy.deepcopy(bar)}},
            "bounds": {"all": {"total": 8.7, "se": 0.05, "episodes": 2000}},
            "claims": [{"claim": "x", "ours": "y", "agrees": "yes"}]}


def _cached(tmp_path, result, blob=True):
    cache = EvaluationCache(str(tmp_path / "cache"))
    settings = {"episodes": 10}
    path = None
    if blob:
        path = tmp_path / "net.msgpack"
        path.write_bytes(b"params")
        (tmp_path / "net.json").write_text("{}")
        path = str(path)
    stored = cache.store(path, settings, result)
    return cache, path, settings, stored


def test_sound_records_are_read_back(tmp_path):
    cache, blob, settings, _ = _cached(tmp_path, _evaluation())
    assert cache.load(blob, settings, check_evaluation) == _evaluation()
    cache, _, settings, _ = _cached(tmp_path, _bound(), blob=False)
    assert cache.load(None, settings, check_bound) == _bound()
    check_figure(Fields("f.json"), _figure())


@pytest.mark.parametrize("edit, key", [
    (lambda r: r.pop("reward"), "reward is missing"),
    (lambda r: r["reward"].update(mean="abc"), "reward.mean must be a number or null, got 'abc'"),
    (lambda r: r["reward"].pop("sd"), "reward.sd is missing"),
    (lambda r: r.update(episodes=1.5), "episodes must be an integer, got 1.5"),
    (lambda r: r["per_strategy"]["with_fog"]["rpe"].update(mean=[1]), "per_strategy.with_fog.rpe.mean must be a"),
    (lambda r: r["outcomes"].update(caught="2"), "outcomes.caught must be an integer, got '2'"),
    (lambda r: r.update(greedy="no"), "greedy must be true or false, got 'no'"),
    (lambda r: r["setting"].update(strategies="patrol"), "setting.strategies must be a list"),
    (lambda r: r.pop("seconds"), "seconds is missing"),
])
def test_a_damaged_cached_evaluation_is_refused_naming_file_and_key(tmp_path, edit, key):
    result = _evaluation()
    edit(result)
    cache, blob, settings, stored = _cached(tmp_path, result)
    with pytest.raises(ValueError) as e:
        cache.load(blob, settings, check_evaluation)
    assert str(e.value).startswith(f"{stored}: {key}") and "delete it" in str(e.value)


def test_a_damaged_cached_bound_is_refused_naming_file_and_key(tmp_path):
    cache, _, settings, stored = _cached(tmp_path, dict(_bound(), total="8"), blob=False)
    with pytest.raises(ValueError, match=r"bound_\w+\.json: total must be a number, got '8'"):
        cache.load(None, settings, check_bound)


@pytest.mark.parametrize("edit, key", [
    (lambda r: r["results"]["all"]["CNN"].pop("reward"), "results.all.CNN.reward is missing"),
    (lambda r: r["results"]["all"]["VNN"]["reward"].update(mean="abc"), "results.all.VNN.reward.mean must be"),
    (lambda r: r["results"]["all"].update({"VNN strong": 3}), "results.all['VNN strong'] must be a JSON object"),
    (lambda r: r["claims"].append({"claim": "x", "ours": "y"}), "claims[1].agrees is missing"),
    (lambda r: r.update(figures=["five"]), "figures[0] must be a figure number"),
    (lambda r: r.update(figures=[]), "figures must name at least one figure"),
    (lambda r: r["bounds"]["all"].update(total=None), "bounds.all.total must be a number, got None"),
])
def test_a_damaged_standard_figure_is_refused_naming_file_and_key(tmp_path, edit, key):
    rec = _figure()
    edit(rec)
    (tmp_path / "figure_standard.json").write_text(json.dumps(rec))
    with pytest.raises(ValueError) as e:
        stored_standard(str(tmp_path))
    assert str(e.value).startswith(f"{tmp_path / 'figure_standard.json'}: {key}")


@pytest.mark.parametrize("reuse", [True, False])
def test_a_cache_file_that_cannot_be_written_is_refused_before_the_evaluation(tmp_path, reuse):
    """The bar's result is stored after its evaluation: a folder at the cache file's name is refused when the cache
    is asked for it, before the evaluation (also with --no-cache, which still stores)."""
    cache = EvaluationCache(str(tmp_path / "cache"), reuse=reuse)
    os.makedirs(cache.path(None, {"game": 1}))
    with pytest.raises(ValueError, match="cache file .* is a folder"):
        cache.load(None, {"game": 1}, check_bound)
    assert cache.load(None, {"game": 2}, check_bound) is None  # a writable name: nothing stored, nothing refused
