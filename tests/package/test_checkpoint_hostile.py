"""Hostile input for jaxdc.checkpoint: non-finite states are neither saved nor restored, damaged bytes are found,
a failed save (full disk) leaves no partial folder and names the folder."""

from __future__ import annotations

import errno
import glob
import os
import signal

import numpy as np
import orbax.checkpoint as ocp
import pytest

from jaxdc import checkpoint


def _state(nu=1.0):
    return {"params": {"w": np.arange(6, dtype=np.float32).reshape(2, 3)},
            "opt_state": {"nu": np.full((2, 3), nu, np.float32)}, "update": np.int32(4)}


def _unchecked_save(monkeypatch, directory, step, state):
    """Write ``state`` as ``save`` would, without its finiteness check (what a damaged or older file holds)."""
    with monkeypatch.context() as m:
        m.setattr(checkpoint, "check_finite", lambda *a, **k: None)
        checkpoint.save(directory, step, state, {"net": "x"})


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_save_refuses_a_non_finite_state_and_writes_nothing(tmp_path, bad):
    with pytest.raises(ValueError, match=r"refusing to save checkpoint 4 .* 6 NaN or infinite values .*/opt_state/nu"):
        checkpoint.save(tmp_path / "c", 4, _state(bad), {"net": "x"})
    assert checkpoint.steps(tmp_path / "c") == []


def test_restore_refuses_a_non_finite_step_and_names_it(tmp_path, monkeypatch):
    d = tmp_path / "c"
    checkpoint.save(d, 4, _state(), {"net": "x"})
    _unchecked_save(monkeypatch, d, 8, _state(np.nan))
    with pytest.raises(checkpoint.Damaged, match=r"step 8 is damaged: it holds 6 NaN .*/opt_state/nu"):
        checkpoint.restore(d, _state(), {"net": "x"})
    assert checkpoint.intact_steps(d, _state(), {"net": "x"}) == [4]
    restored, _ = checkpoint.restore(d, _state(), step=4)
    np.testing.assert_array_equal(restored["params"]["w"], _state()["params"]["w"])


def test_flipped_bytes_of_a_step_are_found(tmp_path):
    """Bytes changed in the data file of a step (compressed) give an unreadable step or other arrays, here
    non-finite ones; either way the step is refused, never restored silently."""
    d = tmp_path / "c"
    state = {"params": {"w": np.random.RandomState(0).randn(2000).astype(np.float32)}}
    checkpoint.save(d, 4, state, {"net": "x"})
    checkpoint.save(d, 8, state, {"net": "x"})
    files = [f for f in glob.glob(str(d / "8" / "state" / "**"), recursive=True) if os.path.isfile(f)]
    path = max(files, key=os.path.getsize)  # the arrays' data
    with open(path, "r+b") as f:
        data = bytearray(f.read())
        for i in range(len(data) // 2, len(data) // 2 + 16):
            data[i] ^= 0xFF
        f.seek(0)
        f.write(data)
    with pytest.raises(checkpoint.Damaged, match="step 8 is damaged|step 8: state unreadable"):
        checkpoint.restore(d, state)
    assert checkpoint.intact_steps(d, state) == [4]


def test_arrays_other_than_those_saved_are_found_by_their_digest(tmp_path, monkeypatch):
    """Finite values that differ from those saved (what changed bytes may give) are refused too."""
    d = tmp_path / "c"
    checkpoint.save(d, 4, _state(), {"net": "x"})
    with monkeypatch.context() as m:
        m.setattr(checkpoint, "digest", lambda tree: "0" * 64)  # the digest of other arrays
        checkpoint.save(d, 8, _state(), {"net": "x"})
    with pytest.raises(checkpoint.Damaged, match="step 8 is damaged: its arrays differ from those saved"):
        checkpoint.restore(d, _state())
    assert checkpoint.intact_steps(d, _state()) == [4]


def test_a_failed_save_removes_its_partial_folder_and_names_the_folder(tmp_path, monkeypatch):
    d = tmp_path / "c"
    checkpoint.save(d, 4, _state(), {"net": "x"})

    def full(*args, **kwargs):
        assert glob.glob(str(d / "*.orbax-checkpoint-tmp*"))  # the save was under way
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(ocp.handlers.JsonCheckpointHandler, "_save_fn", full)
    with pytest.raises(checkpoint.WriteError, match="No space left on device") as e:
        checkpoint.save(d, 8, _state(), {"net": "x"})
    assert isinstance(e.value, ValueError) and e.value.errno == errno.ENOSPC and str(d) in str(e.value)
    monkeypatch.undo()
    assert sorted(os.listdir(d)) == ["4"] and checkpoint.steps(d) == [4]
    checkpoint.save(d, 8, _state(), {"net": "x"})  # the disk has room again
    assert checkpoint.steps(d) == [4, 8]


def test_a_ctrl_c_during_a_save_stops_the_program_after_the_write(tmp_path, monkeypatch):
    """The signal arrives while orbax writes (from its writer thread); the step is complete and restores, and
    the KeyboardInterrupt comes once ``save`` has finished."""
    d = tmp_path / "c"
    original = ocp.handlers.JsonCheckpointHandler._save_fn
    sent = []

    def interrupted(*args, **kwargs):
        if not sent:
            sent.append(os.kill(os.getpid(), signal.SIGINT))
        return original(*args, **kwargs)

    monkeypatch.setattr(ocp.handlers.JsonCheckpointHandler, "_save_fn", interrupted)
    with pytest.raises(KeyboardInterrupt):
        checkpoint.save(d, 4, _state(), {"net": "x"})
    monkeypatch.undo()
    assert sent and sorted(os.listdir(d)) == ["4"] and checkpoint.intact_steps(d, _state()) == [4]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_stale_partial_folder_of_a_killed_save_is_cleared(tmp_path):
    d = tmp_path / "c"
    checkpoint.save(d, 4, _state(), {"net": "x"})
    stale = d / "8.orbax-checkpoint-tmp-1234"
    (stale / "state").mkdir(parents=True)
    assert checkpoint.steps(d) == [4]
    checkpoint.save(d, 8, _state(), {"net": "x"})
    assert sorted(os.listdir(d)) == ["4", "8"]


def test_delete_after_removes_the_later_steps(tmp_path):
    d = tmp_path / "c"
    for s in (4, 8, 12):
        checkpoint.save(d, s, _state(), {"net": "x"})
    assert checkpoint.delete_after(d, 4) == [8, 12] and checkpoint.steps(d) == [4]
