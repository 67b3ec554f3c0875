"""Hostile use of jaxdc.training.lock: a second process on a locked run folder is refused at once, naming the
folder and the holder's process id; a killed holder blocks nothing; a released lock leaves no file."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from jaxdc.training.fields import SettingError
from jaxdc.training.lock import LOCK_NAME, lock_folder
from tests.support.cli_checks import ROOT, checkout_env

HOLD = ("import sys, time; from jaxdc.training.lock import lock_folder; held = lock_folder(sys.argv[1]); "
        "print('held', flush=True); time.sleep(600)")


def _holder(folder):
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(folder)], cwd=ROOT, env=checkout_env(),
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_another_process_on_a_locked_folder_is_refused_naming_it_and_the_holder(tmp_path):
    out = tmp_path / "run"
    proc = _holder(out)
    try:
        with pytest.raises(SettingError) as e:
            lock_folder(str(out))
        assert e.value.render() == (f"--out {out} is in use by another run (process {proc.pid}); wait for it to "
                                    "end, stop it, or choose another --out")
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(30)
    lock_folder(str(out)).release()  # the holder ended: the folder is free


def test_a_killed_holder_blocks_nothing(tmp_path):
    out = tmp_path / "run"
    proc = _holder(out)
    proc.kill()  # SIGKILL: no clean-up ran, the stale lock file stays
    proc.wait(30)
    assert (out / LOCK_NAME).read_text().strip() == str(proc.pid)
    lock = lock_folder(str(out))
    assert (out / LOCK_NAME).read_text().strip() == str(os.getpid())
    lock.release()
    assert not (out / LOCK_NAME).exists()


def test_holds_in_one_process_are_shared_and_the_last_release_removes_the_file(tmp_path):
    out = tmp_path / "run"
    a = lock_folder(str(out))
    b = lock_folder(str(out))  # e.g. a run built to restore a checkpoint while another trains the folder
    (out / "config.json").write_text("{}")
    a.release()
    a.release()  # idempotent
    assert (out / LOCK_NAME).exists() and b.held
    b.release()
    assert sorted(os.listdir(out)) == ["config.json"]


def test_a_folder_made_only_for_the_lock_is_removed_with_it(tmp_path):
    out = tmp_path / "new" / "run"
    lock = lock_folder(str(out))
    assert out.is_dir()
    del lock  # garbage collection releases the hold too
    assert not out.exists() and (tmp_path / "new").is_dir()
