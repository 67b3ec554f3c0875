"""train.dcp --init-from (a warm start, beyond the thesis): the run starts at the source's parameters, records the
source and its SHA-256 so --config reproduces it, and refuses a source of another kind or its own files."""

from __future__ import annotations

import json
import os

import jax
import numpy as np
import pytest

from jaxdc.cli import train_dcp as cli
from jaxdc.core.tree_check import digest
from jaxdc.dcp import learned
from jaxdc.training import dcp
from tests.support.cli_checks import refused, settle, tiny_run

# 32 updates of 4 envs x 8 steps on a 4x4 grid, one evaluation at the end.
TINY = ["--net", "linear", "--grid-size", "4", "--total-reward", "6", "--energy", "4", "8", "--risk", "low",
        "--steps", "1024", "--envs", "4", "--t-max", "8", "--eval-every", "1024", "--eval-episodes", "10",
        "--no-progress"]


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    return tiny_run(cli.main, TINY, tmp_path_factory)



def test_a_warm_start_begins_at_the_source_and_config_reproduces_it(source, tmp_path):
    out = str(tmp_path / "warm")
    # another risk map: what a warm start is for (fine-tuning a network on a new setting)
    argv = TINY + ["--risk", "high", "--init-from", source, "--out", out]
    run = cli.Run(cli.build_parser().parse_args(argv))
    start = run.trainer.init(jax.random.PRNGKey(3)).params
    trained = learned.load(source).params
    jax.tree_util.tree_map(np.testing.assert_array_equal, start, trained)  # not a fresh initialisation

    assert cli.main(argv) == 0
    with open(os.path.join(out, "config.json")) as f:
        meta = json.load(f)
    assert meta["init_from"] == source and meta["init_sha256"] == digest(trained)
    again, _ = settle(cli, "dcp", ["--config", os.path.join(out, "config.json"), "--eval-episodes", "10"])
    assert again.init_from == source and again.risk == "high"
    # a resume with the same warm start is the same run: nothing left to train
    assert cli.main(argv + ["--resume"]) == 0


def test_a_fresh_run_records_no_warm_start(source):
    with open(os.path.join(source, "config.json")) as f:
        assert "init_from" not in json.load(f)


def test_a_warm_start_of_another_kind_or_onto_its_own_files_is_refused(source, capsys, tmp_path):
    out = str(tmp_path / "x")
    refused(cli.main, TINY + ["--grid-size", "5", "--init-from", source, "--out", out], capsys,
            "init_from", "grid_size is 4")
    refused(cli.main, TINY + ["--net", "enn", "--init-from", source, "--out", out], capsys,
            "init_from", "net is 'linear'")
    refused(cli.main, TINY + ["--observation", "general", "--init-from", source, "--out", out], capsys,
            "init_from", "observation is 'thesis'")
    refused(cli.main, ["--net", "eqn", "--grid-size", "4", "--init-from", source, "--out", out], capsys,
            "init_from", "n-step Q-learning")
    refused(cli.main, ["--net", "enn", "--heuristic-rows", "11", "--init-from", "enn", "--steps", "1024",
                       "--out", out], capsys, "init_from", "heuristic_rows is 10")  # the thesis' ENN: ten rows
    refused(cli.main, TINY + ["--init-from", source, "--out", source, "--resume"], capsys, "--out")
    refused(cli.main, TINY + ["--init-from", str(tmp_path / "missing"), "--out", out], capsys, "missing")
    assert not os.path.exists(out)


def test_settings_refuse_a_non_string_source():
    with pytest.raises(TypeError, match="init_from"):
        dcp.DCPSettings(net="enn", config=dcp.a2c.A2CConfig(), init_from=3)  # type: ignore[arg-type]
