"""Hostile input for `python -m train.ship` (jaxdc.cli.train_ship): its flags, its output folders, Ctrl-C
stopping its child trainings.

Every bad value is refused before any work with a non-zero exit and one line naming the flag (or the file and
key), the value and the allowed range, without a traceback; no NaN or Infinity reaches a file or stdout; an
interruption leaves the old files or the complete new set.
"""

from __future__ import annotations

import os
import signal
import time

import pytest

from jaxdc.cli import train_ship
from tests.support.cli_checks import cli_process, refused, wait_for

# ----------------------------------------------------------------------------- flags: train.ship

@pytest.mark.parametrize("extra, needles", [
    (["--seed", "99999999999999999999"], ["--seed", "4294967295"]),
    (["--jobs", "0"], ["--jobs", ">= 1"]),
])
def test_train_ship_refuses_bad_flags(extra, needles, capsys):
    refused(train_ship.main, ["--only", "enn"] + extra, capsys, *needles)


def test_train_ship_output_folders_are_checked_first(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    refused(train_ship.main, ["--only", "enn", "--runs", str(tmp_path / "runs"), "--out", str(blocker / "assets")],
            capsys, "--out", "is a file")
    assert not (tmp_path / "runs").exists()


# ----------------------------------------------------------------------------- Ctrl-C (subprocesses)


def test_ctrl_c_in_train_ship_stops_its_children(tmp_path):
    runs = tmp_path / "runs"
    with cli_process(["train.ship", "--only", "enn", "--steps", "100000000", "--runs", str(runs),
                      "--out", str(tmp_path / "assets")]) as proc:
        assert wait_for(lambda: (runs / "enn.log").exists(), 30)
        time.sleep(1.0)
        children = _children(proc.pid)
        assert children, "train.ship started no training"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().splitlines()[-1] == "python -m train.ship: interrupted", err
    assert not [pid for pid in children if os.path.exists(f"/proc/{pid}") and not _zombie(pid)]
    assert not (tmp_path / "assets").exists()


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (from /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    if int(f.read().split(")")[-1].split()[1]) == pid:
                        found.append(int(entry))
            except (OSError, ValueError, IndexError):
                pass
    return found


def _zombie(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] == "Z"
    except OSError:
        return True
