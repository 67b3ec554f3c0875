"""Hostile input for `python -m train.dcp` (jaxdc.cli.train_dcp and the run loop behind it): flags, output
folders, resuming, NaN stops, corrupt checkpoints and Ctrl-C.

Every bad value is refused before any work with a non-zero exit and one line naming the flag (or the file and
key), the value and the allowed range, without a traceback; no NaN or Infinity reaches a file or stdout; an
interruption leaves the old files or the complete new set.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import time

import jax.numpy as jnp
import pytest

from jaxdc import checkpoint
from jaxdc.agents import a2c
from jaxdc.cli import train_dcg, train_dcp
from tests.support.cli_checks import (
    cli_process,
    refused,
    refused_leaving_no_run,
    tiny_run,
    wait_for,
)

# 8 updates of 4 envs x 8 steps on a 4x4 grid; one evaluation and checkpoint at the end.
TINY = ["--net", "linear", "--grid-size", "4", "--total-reward", "6", "--energy", "4", "8", "--risk", "low",
        "--steps", "256", "--envs", "4", "--t-max", "8", "--eval-every", "256", "--eval-episodes", "8",
        "--no-progress"]
DCG = ["--net", "vnn", "--grid-size", "3", "--total-reward", "3", "--strategies", "restricted", "--steps", "256",
       "--envs", "4", "--t-max", "8", "--eval-every", "256", "--eval-episodes", "8", "--no-progress"]


def _strict(path):
    def refuse(c):
        raise AssertionError(f"{path}: non-strict JSON constant {c}")
    with open(path) as f:
        return json.load(f, parse_constant=refuse)


# ----------------------------------------------------------------------------- flags: train.dcp

@pytest.mark.parametrize("extra, needles", [
    (["--net", "dqn"], ["invalid choice"]),
    (["--net", "eqn", "--eval-epsilon", "5"], ["--eval-epsilon", "[0, 1]", "5"]),
    (["--lr", "0"], ["--lr must be > 0"]),
    (["--lr", "nan"], ["--lr", "NaN", "--lr must be > 0"]),
    (["--entropy", "inf"], ["--entropy", "inf"]),
    (["--value-coef", "-1"], ["--value-coef", ">= 0"]),
    (["--max-grad-norm", "inf"], ["--max-grad-norm", "inf"]),
    (["--clip-eps", "1.5"], ["--clip-eps must be in (0, 1)"]),
    (["--gae-lambda", "-0.1"], ["--gae-lambda must be in [0, 1]"]),
    (["--minibatches", "3"], ["minibatches (3) must divide num_envs * t_max (32)"]),
    (["--seed", "99999999999999999999"], ["--seed", "4294967295"]),
    (["--seeds", "0,99999999999999999999"], ["--seeds", "4294967295"]),
    (["--seeds", "0,x"], ["--seeds must be comma-separated ints"]),
    (["--seeds", "1,1"], ["--seeds must be distinct"]),
    (["--devices", "64"], ["--devices 64: JAX sees only"]),
    (["--steps", "0"], ["--steps must be an integer >= 1"]),
    (["--steps", "-5"], ["--steps must be an integer >= 1"]),
    (["--steps", "16"], ["total_steps (16) must be >= num_envs * t_max (32)"]),
    (["--steps", "1000000000000"], ["--steps", "2147483647"]),
    (["--max-steps", "3000000000"], ["--max-steps", "2147483647"]),
    (["--energy", "inf", "inf"], ["--energy", "finite", "inf"]),
    (["--energy", "1e40", "1e40"], ["--energy", "16777216"]),
    (["--energy", "nan", "8"], ["--energy", "NaN"]),
    (["--energy", "9", "8"], ["exceeds the maximum"]),
    (["--min-total-reward", "7"], ["--min-total-reward (7) exceeds --total-reward (6)"]),
    (["--min-total-reward", "0"], ["--min-total-reward must be an integer >= 1"]),
    (["--grid-size", "1"], ["--grid-size", ">= 2", "1"]),
    (["--grid-size", "0"], ["--grid-size", ">= 2", "0"]),
    (["--energy-tilt", "1"], ["--energy-tilt", "--energy-range"]),
    (["--energy-tilt", "9", "--energy-range", "4", "8"], ["--energy-tilt", "9"]),
    (["--energy-tilt", "nan", "--energy-range", "4", "8"], ["--energy-tilt", "NaN"]),
])
def test_train_dcp_refuses_bad_flags(extra, needles, tmp_path, capsys):
    refused_leaving_no_run(train_dcp.main, TINY + extra, tmp_path / "run", capsys, *needles)


@pytest.mark.parametrize("cli, argv, needles", [
    (train_dcp, TINY + ["--eval-epsilon", "0.1"], ["--eval-epsilon", "--net eqn only", "'linear'"]),
    (train_dcp, TINY + ["--target-every", "64"], ["--target-every", "--net eqn only"]),
    (train_dcg, DCG + ["--alpha", "0.01"], ["--alpha", "--net emnn only", "'vnn'"]),
])
def test_a_flag_that_does_not_apply_is_refused_not_ignored(cli, argv, needles, tmp_path, capsys):
    refused_leaving_no_run(cli.main, argv, tmp_path / "run", capsys, *needles)


def test_train_dcp_refuses_a_batch_too_big_for_memory_before_compiling(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**20))
    out = tmp_path / "run"
    refused(train_dcp.main, TINY + ["--out", str(out), "--envs", "4096", "--steps", "65536"], capsys,
            "--envs", "--t-max", "MiB")
    assert not (out / "config.json").exists()


def test_train_dcp_refuses_evaluation_episodes_too_many_for_memory(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**24))
    out = tmp_path / "run"
    refused(train_dcp.main, TINY + ["--out", str(out), "--eval-episodes", "100000000"], capsys,
            "100000000 evaluation episodes", "lower the number of episodes")
    assert not (out / "config.json").exists()


def test_train_dcp_out_under_a_file_is_refused_before_work(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    refused(train_dcp.main, TINY + ["--out", str(blocker / "run")], capsys, "--out", "is a file")
    assert blocker.read_text() == "x"


def test_train_dcp_tensorboard_folder_blocked_by_a_file(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "tb").write_text("x")
    refused(train_dcp.main, TINY + ["--out", str(out), "--tensorboard"], capsys, "--tensorboard", "tb")
    assert sorted(os.listdir(out)) == ["tb"]


def test_train_dcp_read_only_out_is_refused(read_only_folder, capsys):
    refused(train_dcp.main, TINY + ["--out", str(read_only_folder / "run")], capsys, "--out", "not writable")
    assert os.listdir(read_only_folder) == []


# ----------------------------------------------------------------------------- runs: resume, NaN, corrupt

@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    return tiny_run(train_dcp.main, TINY, tmp_path_factory)


def test_run_files_are_strict_json(finished):
    meta = _strict(os.path.join(finished, "config.json"))
    assert meta["energy"] == [4.0, 8.0]


def test_resume_mismatch_names_the_differing_keys(finished, capsys):
    err = refused(train_dcp.main, TINY + ["--out", finished, "--resume", "--lr", "0.003"], capsys,
                  "algorithm.lr: checkpoint has 0.0001, this run has 0.003")
    assert "algorithm.gamma" not in err


def test_resume_of_a_finished_run_says_so(finished, capsys):
    assert train_dcp.main(TINY + ["--out", finished, "--resume"]) == 0
    err = capsys.readouterr().err
    assert "already finished" in err and os.path.join(finished, "checkpoints") in err


@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
def test_a_corrupt_checkpoint_is_one_clear_error(finished, tmp_path, capsys):
    out = str(tmp_path / "corrupt")
    shutil.copytree(finished, out)
    for root, _, files in os.walk(os.path.join(out, "checkpoints")):
        if os.path.basename(root) == "d":
            for name in files:
                with open(os.path.join(root, name), "wb") as f:
                    f.write(b"\x00garbage")
    err = refused(train_dcp.main, TINY + ["--out", out, "--resume"], capsys, "corrupt", "checkpoints")
    assert "Event loop is closed" not in err and "tensorstore_spec" not in err


def test_nan_stop_before_any_checkpoint_says_none_exists(tmp_path, monkeypatch, capsys):
    loss = a2c.a2c_loss

    def nan_loss(*args, **kwargs):
        value, aux = loss(*args, **kwargs)
        return value * jnp.nan, dict(aux, loss=value * jnp.nan)

    monkeypatch.setattr(a2c, "a2c_loss", nan_loss)
    out = tmp_path / "nan"
    assert train_dcp.main(TINY + ["--out", str(out)]) == train_dcp.EXIT_NAN
    err = capsys.readouterr().err
    assert "No checkpoint was written yet" in err and "last good checkpoint" not in err
    assert checkpoint.steps(out / "checkpoints") == [] and not (out / "metrics.csv").exists()
    _strict(out / "config.json")


# ----------------------------------------------------------------------------- Ctrl-C (subprocesses)


def test_ctrl_c_in_train_dcp_exits_130_and_leaves_a_consistent_run(tmp_path):
    out = tmp_path / "run"
    argv = [a for a in TINY]
    argv[argv.index("--steps") + 1] = "2000000"
    argv[argv.index("--eval-every") + 1] = "64"
    with cli_process(["train.dcp", *argv, "--out", str(out)]) as proc:
        assert wait_for(lambda: checkpoint.steps(out / "checkpoints"), 60), proc.stderr
        time.sleep(0.5)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == ["python -m train.dcp: interrupted"], err
    steps = checkpoint.steps(out / "checkpoints")
    with open(out / "metrics.csv", newline="") as f:
        updates = [int(r["updates"]) for r in csv.DictReader(f)]
    assert steps and updates[: len(updates)] == sorted(updates) and steps[-1] <= updates[-1]
    assert not [n for n in os.listdir(out) if n.startswith(".tmp-")]
    _strict(out / "config.json")


# ----------------------------------------------------------------------------- an output that is an input


@pytest.mark.parametrize("as_folder", [False, True])
def test_config_file_in_the_run_folder_refused(tmp_path, capsys, as_folder):
    """`--config D/config.json --out D` (a fresh run) would overwrite the configuration it reads."""
    from jaxdc.training.dcp import run_metadata

    settings, _ = train_dcp.settle(train_dcp.build_parser().parse_args([]))
    folder = tmp_path / "D"
    folder.mkdir()
    text = json.dumps(run_metadata(settings, [0]))
    (folder / "config.json").write_text(text)
    config = str(folder) if as_folder else str(folder / "config.json")
    refused(train_dcp.main, ["--config", config, "--out", str(folder), "--no-progress"], capsys,
            "config.json", "would overwrite the input --config")
    assert (folder / "config.json").read_text() == text


# ----------------------------------------------------------------------------- a run folder's fixed names


def _no_build(monkeypatch):
    """Fail the test if a run builds its trainer: the refusals below come before any work."""
    def build(*args, **kwargs):
        raise AssertionError("the trainer was built before the refusal")

    monkeypatch.setattr(a2c, "make_train", build)


def _block(path, how):
    if how == "dangling link":
        os.symlink(os.path.join(os.path.dirname(path), "nowhere", "x"), path)
    elif how == "file":
        with open(path, "w") as f:
            f.write("x")
    else:
        os.mkdir(path)


@pytest.mark.parametrize("cli, argv", [(train_dcp, TINY), (train_dcg, DCG)], ids=["dcp", "dcg"])
@pytest.mark.parametrize("name, how, needles", [
    ("checkpoints", "dangling link", ["--out's checkpoints folder", "symbolic link", "does not exist"]),
    ("checkpoints", "file", ["--out's checkpoints folder", "is a file, not a folder"]),
    ("provenance.json", "folder", ["--out file", "provenance.json", "is a folder, not a file"]),
    ("config.json", "dangling link", ["--out file", "config.json", "does not exist"]),
    ("metrics.csv", "folder", ["--out file", "metrics.csv", "is a folder, not a file"]),
])
def test_a_blocked_name_in_the_run_folder_is_refused_before_any_work(cli, argv, name, how, needles, tmp_path,
                                                                    capsys, monkeypatch):
    """A name the run writes into its folder that no write can create (a checkpoints/ that is a file or a dangling
    link, a folder at provenance.json) is refused before the trainer is built, naming it: the run would train to
    the end and lose it all at the first write. Nothing is written."""
    out = tmp_path / "run"
    out.mkdir()
    _block(str(out / name), how)
    _no_build(monkeypatch)
    t0 = time.monotonic()
    refused(cli.main, argv + ["--out", str(out)], capsys, str(out / name), *needles)
    assert time.monotonic() - t0 < 30
    assert os.listdir(out) == [name]


def test_a_blocked_metrics_file_of_one_seed_is_refused(tmp_path, capsys, monkeypatch):
    """With several seeds each writes its own metrics-sSEED.csv: each name is checked."""
    out = tmp_path / "run"
    out.mkdir()
    (out / "metrics-s1.csv").mkdir()
    _no_build(monkeypatch)
    refused(train_dcp.main, TINY + ["--seeds", "0,1", "--out", str(out)], capsys,
            str(out / "metrics-s1.csv"), "is a folder, not a file")
    assert os.listdir(out) == ["metrics-s1.csv"]


def test_a_tensorboard_folder_linked_out_of_the_run_folder_is_refused(tmp_path, capsys, monkeypatch):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = tmp_path / "run"
    out.mkdir()
    (out / "tb").symlink_to(elsewhere)
    _no_build(monkeypatch)
    refused(train_dcp.main, TINY + ["--tensorboard", "--out", str(out)], capsys, "--tensorboard", str(out / "tb"),
            "outside the run folder")
    assert os.listdir(elsewhere) == [] and os.listdir(out) == ["tb"]
