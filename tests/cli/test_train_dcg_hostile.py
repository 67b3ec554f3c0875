"""Hostile input for `python -m train.dcg` (jaxdc.cli.train_dcg).

Every bad value is refused before any work with a non-zero exit and one line naming the flag (or the file and
key), the value and the allowed range, without a traceback; no NaN or Infinity reaches a file or stdout; an
interruption leaves the old files or the complete new set.
"""

from __future__ import annotations

import json
import os

import pytest

from jaxdc.cli import train_dcg
from tests.support.cli_checks import refused_leaving_no_run

DCG = ["--net", "vnn", "--grid-size", "3", "--total-reward", "3", "--strategies", "restricted", "--steps", "256",
       "--envs", "4", "--t-max", "8", "--eval-every", "256", "--eval-episodes", "8", "--no-progress"]


# ----------------------------------------------------------------------------- flags: train.dcg

@pytest.mark.parametrize("extra, needles", [
    (["--net", "dqn"], ["invalid choice"]),
    (["--history", "0"], ["--history", ">= 1"]),
    (["--history", "-3"], ["--history", ">= 1"]),
    (["--net", "emnn", "--history", "0"], ["--history must be an integer >= 1, got 0"]),
    (["--net", "omn_conn", "--history", "-1"], ["--history must be an integer >= 1, got -1"]),
    (["--net", "imnn", "--history", "x"], ["--history must be an integer"]),
    (["--alpha", "inf"], ["--alpha", "inf"]),
    (["--alpha", "nan"], ["--alpha", "NaN"]),
    (["--alpha", "-0.001"], ["--alpha must be >= 0"]),
    (["--omn-lr", "nan"], ["--omn-lr", "NaN"]),
    (["--net", "emnn", "--omn-lr", "0.001"], ["--omn-lr sets OMN's learning rate and applies to --net omn_conn only"]),
    (["--net", "omn_conn", "--omn-lr", "0"], ["--omn-lr must be > 0"]),
    (["--gamma", "inf"], ["--gamma", "inf"]),
    (["--seed", "-1"], ["--seed", ">= 0"]),
    (["--envs", "16", "--steps", "16"], ["total_steps (16) must be >= num_envs * t_max (128)"]),
    (["--strategies", "patrol,sneaky"], ["unknown strategy 'sneaky'"]),
    (["--strategies", ""], ["strategies must not be empty"]),
    (["--strategies", " , "], ["strategies must not be empty"]),
    (["--energy", "0"], ["--energy must be > 0"]),
    (["--energy", "-3"], ["--energy must be > 0"]),
    (["--energy", "inf"], ["--energy", "finite"]),
    (["--energy", "1e40"], ["--energy", "16777216"]),
    (["--grid-size", "0"], ["--grid-size", ">= 2"]),
    (["--grid-size", "1"], ["--grid-size must be an integer >= 2, got 1"]),
    (["--reward-area", "0"], ["--reward-area must be an integer >= 1"]),
    (["--reward-area", "4"], ["reward_area must be between 1 and grid_size (3), got 4"]),
    (["--min-reward-area", "1"], ["min_reward_area=1 needs a reward_area"]),
    (["--reward-area", "2", "--min-reward-area", "3"],
     ["min_reward_area must be between 1 and reward_area (2), got 3"]),
    (["--reward-area", "2", "--min-reward-area", "0"], ["--min-reward-area must be an integer >= 1"]),
])
def test_train_dcg_refuses_bad_flags(extra, needles, tmp_path, capsys):
    refused_leaving_no_run(train_dcg.main, DCG + extra, tmp_path / "run", capsys, *needles)


def test_train_dcg_ship_path_is_checked_before_training(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    refused_leaving_no_run(train_dcg.main, DCG + ["--ship", str(blocker / "net.msgpack")], tmp_path / "run", capsys,
                           "--ship", "is a file")


def test_train_dcg_ship_over_the_run_config_refused(tmp_path, capsys):
    """`--ship RUN/config` writes RUN/config.json as the sidecar: the run's own config.json (which a resume
    reads) is refused."""
    out = tmp_path / "run"
    refused_leaving_no_run(train_dcg.main, DCG + ["--ship", str(out / "config")], out, capsys,
                           "--ship", "config.json", "would overwrite the input --out")


# ----------------------------------------------------------------------------- --config FILE: train.dcg

CONFIG = os.path.join(os.path.dirname(__file__), "..", "..", "results", "dcg", "omn_conn_general_tilt4", "config.json")


@pytest.mark.parametrize("change, needles", [
    ({"alpha": "0.001"}, ["alpha='0.001'", "not a string"]),
    ({"reward_area": 9}, ["reward_area must be between 1 and grid_size (5), got 9"]),
    ({"strategies": ["patrol", "bogus"]}, ["unknown strategy 'bogus'"]),
    ({"energy": "1e400"}, ["too large for a float", '"inf"']),
])
def test_train_dcg_config_file_refusals_name_the_file(change, needles, tmp_path, capsys):
    """A run's config.json whose value is refused names the file, also when the refusal comes from the game's own
    check of a value the user never typed as a flag; a string is no number, and 1e400 is no "inf"."""
    with open(CONFIG) as f:
        text = f.read()
    meta = json.loads(text)
    meta.update({k: v for k, v in change.items() if k != "energy"})
    text = json.dumps(meta)
    if "energy" in change:  # a JSON number too large for a float: Python's json reads it as infinity
        text = text.replace('"energy": 15.0', f'"energy": {change["energy"]}')
        assert change["energy"] in text
    path = tmp_path / "cfg.json"
    path.write_text(text)
    refused_leaving_no_run(train_dcg.main, ["--config", str(path), "--steps", "256", "--envs", "4", "--t-max", "8",
                                            "--no-progress"], tmp_path / "run", capsys, "cfg.json", *needles)
