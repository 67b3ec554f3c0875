"""The train.dcp command line: a tiny run, exact --resume, NaN stop, and clear errors on bad input."""

from __future__ import annotations

import csv
import os
import shutil

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc import checkpoint
from jaxdc.agents import a2c
from train import dcp as cli

# 128 updates of 4 envs x 8 steps on a 4x4 grid; evaluations/checkpoints at updates 64 and 128.
TINY = ["--net", "linear", "--grid-size", "4", "--total-reward", "6", "--energy", "4", "8", "--risk", "low",
        "--steps", "4096", "--envs", "4", "--t-max", "8", "--eval-every", "2048", "--eval-episodes", "20",
        "--no-progress"]


def _fails(capsys, argv, match):
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert match in err, err


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("runs") / "tiny")
    assert cli.main(TINY + ["--out", out]) == 0
    return out


def _restore(out, net="linear"):
    args = cli.build_parser().parse_args(TINY + ["--out", out, "--net", net])
    run = cli.Run(args)
    state, _ = checkpoint.restore(run.ckpt_dir, run.trainer.init(jax.random.PRNGKey(0)), run.metadata)
    return state


def test_run_writes_config_metrics_and_checkpoints(finished_run):
    assert os.path.exists(os.path.join(finished_run, "config.json"))
    with open(os.path.join(finished_run, "metrics.csv")) as f:
        rows = list(csv.DictReader(f))
    assert [int(r["env_steps"]) for r in rows] == [2048, 4096]
    assert float(rows[-1]["lr"]) == 0.0 and all(np.isfinite(float(r["eval_reward"])) for r in rows)
    assert checkpoint.steps(os.path.join(finished_run, "checkpoints")) == [64, 128]


def test_resume_ends_with_the_same_parameters(finished_run, tmp_path):
    out = str(tmp_path / "killed")
    shutil.copytree(finished_run, out)
    shutil.rmtree(os.path.join(out, "checkpoints", "128"))  # as if killed after the first checkpoint
    assert cli.main(TINY + ["--out", out, "--resume"]) == 0
    a, b = _restore(finished_run), _restore(out)
    assert int(a.update) == int(b.update) == 128
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    with open(os.path.join(out, "metrics.csv")) as f:
        assert [int(r["updates"]) for r in csv.DictReader(f)] == [64, 128]


def test_nan_loss_stops_and_keeps_the_last_good_checkpoint(finished_run, tmp_path, monkeypatch, capsys):
    out = str(tmp_path / "nan")
    shutil.copytree(finished_run, out)
    shutil.rmtree(os.path.join(out, "checkpoints", "128"))
    good = _restore(out)
    loss = a2c.a2c_loss

    def nan_loss(*args, **kwargs):
        value, aux = loss(*args, **kwargs)
        return value * jnp.nan, dict(aux, loss=value * jnp.nan)

    monkeypatch.setattr(a2c, "a2c_loss", nan_loss)
    assert cli.main(TINY + ["--out", out, "--resume"]) == cli.EXIT_NAN
    assert "NaN" in capsys.readouterr().err
    monkeypatch.undo()
    assert checkpoint.steps(os.path.join(out, "checkpoints")) == [64]
    for x, y in zip(jax.tree_util.tree_leaves(good), jax.tree_util.tree_leaves(_restore(out))):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


@pytest.mark.parametrize("extra, match", [
    (["--net", "dqn"], "invalid choice"),
    (["--steps", "0"], "--steps must be > 0"),
    (["--steps", "-5"], "--steps must be > 0"),
    (["--lr", "0"], "--lr must be > 0"),
    (["--lr", "nan"], "--lr must be > 0"),
    (["--steps", "16"], "total_steps (16) must be >= num_envs * t_max (32)"),
    (["--energy", "9", "8"], "exceeds the maximum"),
])
def test_bad_arguments(capsys, tmp_path, extra, match):
    _fails(capsys, TINY + ["--out", str(tmp_path / "x")] + extra, match)


def test_bad_folders_and_checkpoints(finished_run, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    _fails(capsys, TINY + ["--out", str(blocker / "run")], "not writable")
    _fails(capsys, TINY + ["--out", str(tmp_path / "empty"), "--resume"], "no checkpoint found")
    _fails(capsys, TINY + ["--out", finished_run], "already holds checkpoints")
    _fails(capsys, TINY + ["--out", finished_run, "--resume", "--net", "cnn"], "net: checkpoint has 'linear'")
    _fails(capsys, TINY + ["--out", finished_run, "--resume", "--grid-size", "5"], "grid_size")
    corrupt = str(tmp_path / "corrupt")
    shutil.copytree(finished_run, corrupt)
    for root, _, files in os.walk(os.path.join(corrupt, "checkpoints", "128")):
        for name in files:
            with open(os.path.join(root, name), "wb") as f:
                f.write(b"\x00garbage")
    _fails(capsys, TINY + ["--out", corrupt, "--resume"], "corrupt")


def test_eqn_is_wired_to_nstep_q(tmp_path):
    """--net eqn builds EQN with n-step Q-learning and an epsilon-greedy evaluation (training: test_nstep_q)."""
    from jaxdc.agents import nstep_q
    from jaxdc.nets import EQN

    argv = [a if a != "linear" else "eqn" for a in TINY] + ["--out", str(tmp_path / "eqn"), "--target-every", "256"]
    run = cli.Run(cli.build_parser().parse_args(argv))
    assert isinstance(run.net, EQN) and isinstance(run.config, nstep_q.QConfig)
    assert run.config.target_period == 256 // 32 and run.metadata["net"] == "eqn"
    assert run.metadata["algorithm"]["target_every"] == 256
