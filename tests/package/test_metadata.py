"""jaxdc.metadata: the format of run and parameter-file metadata, and the one upgrade of older files."""

from __future__ import annotations

import json
import os

import pytest

from jaxdc import metadata, pretrained
from jaxdc.agents.a2c import A2CConfig
from jaxdc.agents.nstep_q import QConfig


def test_format_1_a2c_run_gets_every_option_and_setting():
    old = {"format": 1, "net": "enn", "grid_size": 8, "seed": 0,
           "algorithm": {"total_steps": 2048, "num_envs": 4, "t_max": 8, "lr": 3e-4}}
    new = metadata.upgrade(old)
    assert new["format"] == metadata.FORMAT == 2 and new["min_total_reward"] is None
    assert A2CConfig(**new["algorithm"]) == A2CConfig(total_steps=2048, num_envs=4, t_max=8, lr=3e-4)
    assert old["format"] == 1 and "min_total_reward" not in old  # the argument is left alone


def test_format_1_eqn_run_keeps_only_the_q_fields():
    a2c_keys = {"value_coef": 1.0, "entropy_coef": 0.01, "aux_coef": 1.0, "aux_lr": None}
    old = {"format": 1, "net": "eqn", "algorithm": {"total_steps": 2048, "num_envs": 4, "t_max": 8, **a2c_keys}}
    new = metadata.upgrade(old)
    assert QConfig(**new["algorithm"]) == QConfig(total_steps=2048, num_envs=4, t_max=8)
    assert not set(a2c_keys) & set(new["algorithm"])


def test_dcg_settings_and_a_current_file_is_unchanged():
    new = metadata.upgrade({"net": "omn_conn", "problem": "dcg"})  # no "format": format 1
    assert new == {"net": "omn_conn", "problem": "dcg", "reward_area": None, "min_reward_area": None, "format": 2}
    assert metadata.upgrade(new) == new


@pytest.mark.parametrize("bad", [3, "2", True, 0])
def test_unknown_format_is_refused(bad):
    with pytest.raises(ValueError, match="format"):
        metadata.upgrade({"format": bad, "net": "enn"})


def test_parameter_files_record_the_format_and_old_sidecars_read_upgraded(tmp_path):
    params = {"params": {"w": [1.0, 2.0]}}
    path = pretrained.save(tmp_path / "p", params, {"net": "linear", "problem": "dcp", "format": 1})
    with open(str(tmp_path / "p.json")) as f:
        assert json.load(f)["format"] == metadata.FORMAT
    with open(str(tmp_path / "p.json"), "w") as f:  # an old sidecar: no format, no optional settings
        json.dump({"net": "linear", "problem": "dcp"}, f)
    _, meta = pretrained.load(path, net="linear")
    assert meta["format"] == metadata.FORMAT and meta["min_total_reward"] is None


def test_every_shipped_sidecar_reads_in_the_current_format():
    for problem in ("dcp", "dcg"):
        for name in pretrained.shipped_names(problem):
            meta = pretrained.read_metadata(os.path.join(pretrained.ASSETS, problem, name + ".msgpack"))
            assert meta["format"] == metadata.FORMAT, name
