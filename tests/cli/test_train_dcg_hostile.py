"""Hostile input for `python -m train.dcg` (jaxdc.cli.train_dcg).

Every bad value is refused before any work with a non-zero exit and one line naming the flag (or the file and
key), the value and the allowed range, without a traceback; no NaN or Infinity reaches a file or stdout; an
interruption leaves the old files or the complete new set.
"""

from __future__ import annotations

import pytest

from jaxdc.cli import train_dcg
from tests.support.cli_checks import refused

DCG = ["--net", "vnn", "--grid-size", "3", "--total-reward", "3", "--strategies", "restricted", "--steps", "256",
       "--envs", "4", "--t-max", "8", "--eval-every", "256", "--eval-episodes", "8", "--no-progress"]


# ----------------------------------------------------------------------------- flags: train.dcg

@pytest.mark.parametrize("extra, needles", [
    (["--alpha", "inf"], ["--alpha", "inf"]),
    (["--alpha", "nan"], ["--alpha", "NaN"]),
    (["--omn-lr", "nan"], ["--omn-lr", "NaN"]),
    (["--energy", "inf"], ["--energy", "finite"]),
    (["--energy", "1e40"], ["--energy", "16777216"]),
    (["--history", "0"], ["--history", ">= 1"]),
    (["--history", "-3"], ["--history", ">= 1"]),
    (["--grid-size", "0"], ["--grid-size", ">= 2"]),
    (["--seed", "-1"], ["--seed", ">= 0"]),
    (["--gamma", "inf"], ["--gamma", "inf"]),
])
def test_train_dcg_refuses_bad_flags(extra, needles, tmp_path, capsys):
    out = tmp_path / "run"
    refused(train_dcg.main, DCG + ["--out", str(out)] + extra, capsys, *needles)
    assert not out.exists()


def test_train_dcg_ship_path_is_checked_before_training(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    out = tmp_path / "run"
    refused(train_dcg.main, DCG + ["--out", str(out), "--ship", str(blocker / "net.msgpack")], capsys,
            "--ship", "is a file")
    assert not out.exists()


def test_train_dcg_ship_over_the_run_config_refused(tmp_path, capsys):
    """`--ship RUN/config` writes RUN/config.json as the sidecar: the run's own config.json (which a resume
    reads) is refused."""
    out = tmp_path / "run"
    refused(train_dcg.main, DCG + ["--out", str(out), "--ship", str(out / "config")], capsys,
            "--ship", "config.json", "would overwrite the input --out")
    assert not out.exists()
