"""Hostile input for jaxdc.drp.analysis.cache: a damaged stored experiment is named (file and key) and recomputed,
never drawn or tabulated (issue 31)."""

import copy
import json

import numpy as np
import pytest

from jaxdc.drp.analysis.cache import check_experiment, stored_experiment
from jaxdc.drp.analysis.experiment import ExperimentConfig
from jaxdc.drp.analysis.summary import experiment_record
from jaxdc.drp.solve import CLUSTERINGS
from jaxdc.drp.tours import BUILDERS

CONFIG = ExperimentConfig(rewards="4-6", graphs=2, nodes=5, alphas=(0, 5), base="centre", seed=0)


def _record():
    rng = np.random.default_rng(0)
    raw = {(c, b): rng.uniform(1, 2, (2, 2)) for c in CLUSTERINGS for b in BUILDERS}
    return experiment_record(CONFIG.as_dict(), raw, {}, 1.5, list(CONFIG.alphas))


def _stored(tmp_path, record):
    path = tmp_path / "experiment.json"
    path.write_text(json.dumps(record))
    warned = []
    return stored_experiment(str(path), CONFIG, warn=warned.append), warned, str(path)


def test_a_sound_record_is_reused(tmp_path):
    got, warned, _ = _stored(tmp_path, _record())
    assert got is not None and not warned


def _damaged(edit):
    rec = _record()
    edit(rec)
    return rec


@pytest.mark.parametrize("edit, key", [
    (lambda r: r["rows"][3].pop("builder"), "rows[3].builder is missing"),
    (lambda r: r["rows"][0].update(mean="hello"), "rows[0].mean must be a number or null, got 'hello'"),
    (lambda r: r["rows"][0].update(sd=True), "rows[0].sd must be a number or null, got True"),
    (lambda r: r["rows"][1].update(builder="xx"), "rows[1].builder must be one of"),
    (lambda r: r["rows"][1].update(alpha=7), "rows[1].alpha 7 is not one of config.alphas"),
    (lambda r: r["rows"].pop(), "rows have no row for clustering 'pgc'"),
    (lambda r: r["rows"].append(copy.deepcopy(r["rows"][0])), "rows[24] repeats rows[0]"),
    (lambda r: r["rows"].__setitem__(2, "x"), "rows[2] must be a JSON object, got 'x'"),
    (lambda r: r["rows"][0].update(mean=None), "rows[0] must have both mean and sd"),
    (lambda r: r["rows"][0].update(pgc_over_nc="1"), "rows[0].pgc_over_nc must be a number or null"),
    (lambda r: r.update(rows={}), "rows must be a list, got {}"),
    (lambda r: r.pop("wall_seconds"), "wall_seconds is missing"),
])
def test_a_damaged_record_is_named_and_recomputed(tmp_path, edit, key):
    got, warned, path = _stored(tmp_path, _damaged(edit))
    assert got is None and len(warned) == 1
    assert f"{path}: {key}" in warned[0] and "recomputing" in warned[0]


def test_check_experiment_refuses_a_bad_config():
    rec = _record()
    rec["config"]["graphs"] = "2"
    with pytest.raises(ValueError, match=r"x\.json: config\.graphs must be an integer, got '2'"):
        check_experiment(rec, "x.json")
    with pytest.raises(ValueError, match=r"x\.json: the file must hold a JSON object"):
        check_experiment([], "x.json")
