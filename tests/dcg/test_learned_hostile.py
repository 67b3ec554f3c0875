"""Hostile input for the learned DCG loader (jaxdc.dcg.learned): a sidecar whose stored setting is wrong is
refused with the file and the key, by the checks of the flags, strict about JSON types; a history too long for
memory is refused before any network is built."""

from __future__ import annotations

import pytest

from jaxdc import pretrained
from jaxdc.core import memory
from jaxdc.dcg import learned as learned_lib
from tests.support.sidecars import assert_refused_naming_file_and_key, copy_with


def _copy(tmp_path, **changes):
    return copy_with(tmp_path, "dcg", pretrained.shipped_names("dcg")[0], **changes)


@pytest.mark.parametrize("changes, key, words", [
    ({"strategies": 1.5}, "strategies", "list of strategy names"),
    ({"strategies": ["patrol", "nobody"]}, "strategies", "nobody"),
    ({"chase_tie": "x"}, "chase_tie", "one of"),
    ({"obs_history": "no"}, "obs_history", "true or false"),
    ({"obs_history": 1}, "obs_history", "true or false"),
    ({"energy": "inf"}, "energy", "number"),
    ({"energy": [15]}, "energy", "number"),
    ({"alpha": "x"}, "alpha", "number"),
    ({"max_steps": 100.0}, "max_steps", "int"),
    ({"history": -1}, "history", ">= 0"),
    ({"items_on_base": "yes"}, "items_on_base", "true or false"),
    ({"env": {"patrol_target": 3}}, "env", "env.patrol_target"),
])
def test_bad_sidecar_setting_names_the_file_and_key(tmp_path, changes, key, words):
    assert_refused_naming_file_and_key(learned_lib.load, _copy(tmp_path, **changes), key, words)


def test_history_beyond_memory_refused_before_building(tmp_path, monkeypatch):
    """`history: 10**9` reached XLA's RESOURCE_EXHAUSTED; it is refused with the file and the key."""
    monkeypatch.setattr(memory, "available_bytes", lambda: 2**30)
    blob = _copy(tmp_path, history=10**9)
    with pytest.raises(MemoryError, match=r"net\.json: key 'history': 1000000000 history planes"):
        learned_lib.load(blob)


def test_shipped_sidecars_pass():
    for name in pretrained.shipped_names("dcg"):
        learned_lib.check_setting(pretrained.read_metadata(pretrained.shipped("dcg", name)), name)
