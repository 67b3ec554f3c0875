"""Hostile input for the learned DCP loader (jaxdc.dcp.learned): a sidecar whose stored setting is wrong is
refused with the file and the key, by the checks of the flags, strict about JSON types."""

from __future__ import annotations

import shutil

import pytest

from jaxdc import pretrained
from jaxdc.dcp import learned as learned_lib
from tests.support.sidecars import assert_refused_naming_file_and_key, copy_with


def _copy(tmp_path, **changes):
    return copy_with(tmp_path, "dcp", "enn", **changes)


@pytest.mark.parametrize("changes, key, words", [
    ({"energy": 8.0}, "energy", "list of 2"),
    ({"energy": ["x", 16]}, "energy", "numbers > 0"),
    ({"energy": [8, 0]}, "energy", "> 0"),
    ({"energy": [True, 16]}, "energy", "numbers"),
    ({"risk": "nope"}, "risk", "one of"),
    ({"risk": 5}, "risk", "one of"),
    ({"max_steps": 1.5}, "max_steps", "int"),
    ({"max_steps": 10**12}, "max_steps", "2147483647"),
    ({"grid_size": True}, "grid_size", "int"),
    ({"observation": "eyes"}, "observation", "one of"),
    ({"env_items_on_base": "no"}, "env", "true or false"),
    ({"env_start": "moon"}, "env", "env.start"),
    ({"env": []}, "env", "JSON object"),
    ({"init_fraction": 2.0}, "init_fraction", "<= 1"),
    ({"body_features": 64}, "body_features", "list"),
    ({"body_features": [64, 0]}, "body_features", "in [1, 4096], got 0"),
    ({"body_features": [64, 1.5]}, "body_features", "int"),
    ({"body_hidden": 10**6}, "body_hidden", "4096"),
    ({"heuristic_rows": 12}, "heuristic_rows", "in [10, 11], got 12"),
    ({"heuristic_rows": "11"}, "heuristic_rows", "int"),
])
def test_bad_sidecar_setting_names_the_file_and_key(tmp_path, changes, key, words):
    assert_refused_naming_file_and_key(learned_lib.load, _copy(tmp_path, **changes), key, words)


def test_energy_above_the_maximum_names_the_file(tmp_path):
    blob = _copy(tmp_path, energy=[16, 8])
    with pytest.raises(ValueError, match=r"net\.json: its setting does not build the environment: initial energy"):
        learned_lib.load(blob)


def test_a_body_the_network_cannot_build_names_the_file(tmp_path):
    """Seven layers pass the key's type check but not the network's bounds; the parameters of a thesis-sized ENN
    do not fit a recorded wider body."""
    with pytest.raises(ValueError, match=r"net\.json: its network does not build: body_features must hold 1..6"):
        learned_lib.load(_copy(tmp_path, body_features=[8] * 7))
    with pytest.raises(ValueError, match="net.msgpack"):
        learned_lib.load(_copy(tmp_path, body_features=[64, 64, 32], body_hidden=512))
    with pytest.raises(ValueError, match="net.msgpack"):  # ten rows' parameters under a recorded eleventh
        learned_lib.load(_copy(tmp_path, heuristic_rows=11))


def test_shipped_sidecars_pass():
    for name in pretrained.shipped_names("dcp"):
        learned_lib.check_setting(pretrained.read_metadata(pretrained.shipped("dcp", name)), name)


def test_a_sidecar_that_is_a_folder_is_named_as_a_folder(tmp_path):
    """A folder at the sidecar's name is not reported as a missing file."""
    blob = tmp_path / "net.msgpack"
    shutil.copy(pretrained.shipped("dcp", "enn_general"), blob)
    (tmp_path / "net.json").mkdir()
    with pytest.raises(ValueError, match=r"net\.json is a folder, not a JSON file"):
        learned_lib.load(str(blob))
