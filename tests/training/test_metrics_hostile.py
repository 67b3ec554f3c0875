"""Hostile metrics files for jaxdc.training.metrics: a damaged CSV is refused naming the file, the line and the
column, never read as an empty or shorter history."""

from __future__ import annotations

import errno

import pytest

from jaxdc import checkpoint
from jaxdc.io import atomic_write
from jaxdc.training import metrics
from jaxdc.training.metrics import read_rows, write_rows

FIELDS = ("env_steps", "updates", "loss", "eval_reward")
GOOD = "env_steps,updates,loss,eval_reward\n128,4,0.5,1.0\n256,8,0.25,\n"


def _csv(tmp_path, text):
    path = tmp_path / "metrics.csv"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return str(path)


def test_a_sound_file_reads_back_up_to_the_checkpoint(tmp_path):
    path = _csv(tmp_path, GOOD)
    assert [r["updates"] for r in read_rows(path, 8)] == ["4", "8"]
    assert [r["updates"] for r in read_rows(path, 4)] == ["4"]
    assert read_rows(str(tmp_path / "none.csv"), 8) == []


@pytest.mark.parametrize("text, needles", [
    (b"\x8f\x00garbage\xff", ["cannot be read"]),
    ("garbage\n", ["line 1", "header"]),
    ("", ["line 1", "header"]),
    ("env_steps,updates,loss,eval_reward\n128,4,0.5,1.0\n256,8,0.2", ["line 3", "3 values", "truncated"]),
    ("env_steps,updates,loss,eval_reward\n128,4,0.5,1.0,9\n", ["line 2", "5 values"]),
    ("env_steps,updates,loss,eval_reward\n128,4,abc,1.0\n", ["line 2", "column loss", "'abc'"]),
    ("env_steps,updates,loss,eval_reward\n128,4.5,0.5,1.0\n", ["line 2", "column updates", "'4.5'"]),
    ("env_steps,updates,loss,eval_reward\n256,8,0.5,1.0\n128,4,0.5,1.0\n", ["line 3", "after 8"]),
    ("env_steps,updates,updates,eval_reward\n128,4,4,1.0\n", ["line 1", "header"]),
], ids=["binary", "garbage", "empty", "truncated", "extra", "text", "fraction", "order", "duplicate"])
def test_a_damaged_file_is_refused_naming_it(tmp_path, text, needles):
    path = _csv(tmp_path, text)
    with pytest.raises(ValueError) as e:
        read_rows(path, 8)
    for n in [path, *needles, "move it away"]:
        assert n in str(e.value), (n, str(e.value))


def test_a_folder_in_its_place_is_refused_naming_it(tmp_path):
    (tmp_path / "metrics.csv").mkdir()
    with pytest.raises(ValueError, match="metrics.csv is not a file .a folder."):
        read_rows(str(tmp_path / "metrics.csv"), 8)


def test_a_failed_write_names_the_file(tmp_path, monkeypatch):
    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(metrics, "atomic_write", full)
    path = str(tmp_path / "metrics.csv")
    with pytest.raises(checkpoint.WriteError, match="metrics.csv could not be written .No space left on device"):
        write_rows(path, [{"updates": 4}], FIELDS)
    assert atomic_write is not full
