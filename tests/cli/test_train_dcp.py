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
from jaxdc.cli import train_common as common
from jaxdc.cli import train_dcp as cli
from tests.support.cli_checks import refused, resumes_exactly, tiny_run

# 128 updates of 4 envs x 8 steps on a 4x4 grid; evaluations/checkpoints at updates 64 and 128.
TINY = ["--net", "linear", "--grid-size", "4", "--total-reward", "6", "--energy", "4", "8", "--risk", "low",
        "--steps", "4096", "--envs", "4", "--t-max", "8", "--eval-every", "2048", "--eval-episodes", "20",
        "--no-progress"]


def _fails(capsys, argv, match):
    refused(cli.main, argv, capsys, match)


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    return tiny_run(cli.main, TINY, tmp_path_factory)


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
    out = resumes_exactly(cli.main, TINY, finished_run, tmp_path, 128, _restore)
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


def test_bad_folders_and_checkpoints(finished_run, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    _fails(capsys, TINY + ["--out", str(blocker / "run")], "cannot be created")
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
    """--net eqn builds EQN with n-step Q-learning and an epsilon-greedy evaluation (training: test_agents_nstep_q)."""
    from jaxdc.agents import nstep_q
    from jaxdc.nets import EQN

    argv = [a if a != "linear" else "eqn" for a in TINY] + ["--out", str(tmp_path / "eqn"), "--target-every", "256"]
    run = cli.Run(cli.build_parser().parse_args(argv))
    assert isinstance(run.net, EQN) and isinstance(run.config, nstep_q.QConfig)
    assert run.config.target_period == 256 // 32 and run.metadata["net"] == "eqn"
    assert run.metadata["algorithm"]["target_every"] == 256


def test_learner_options_reach_the_config_and_the_metadata(tmp_path):
    argv = TINY + ["--out", str(tmp_path / "ppo"), "--clip-eps", "0.2", "--epochs", "2", "--minibatches", "4",
                   "--gae-lambda", "0.95", "--normalize-advantages", "--reset-slots", "2"]
    run = cli.Run(cli.build_parser().parse_args(argv))
    c = run.config
    assert (c.clip_eps, c.epochs, c.minibatches, c.gae_lambda, c.normalize_advantages, c.reset_slots) == (
        0.2, 2, 4, 0.95, True, 2)
    assert run.metadata["algorithm"]["clip_eps"] == 0.2
    plain = cli.Run(cli.build_parser().parse_args(TINY + ["--out", str(tmp_path / "plain")]))
    assert plain.metadata["format"] == 2
    assert {k: plain.metadata["algorithm"][k] for k in common.LEARNER_OPTIONS} == common.LEARNER_OPTIONS


def _tb_scalars(folder):
    """Tags and steps of the scalars in the TensorBoard event files under ``folder`` (TFRecord framing)."""
    import struct

    from tensorboardX.proto import event_pb2

    found = {}
    for root, _, files in os.walk(folder):
        for name in files:
            data = open(os.path.join(root, name), "rb").read()
            i = 0
            while i < len(data):
                (n,) = struct.unpack("<Q", data[i:i + 8])
                event = event_pb2.Event.FromString(data[i + 12:i + 12 + n])
                i += 12 + n + 4
                for v in event.summary.value:
                    found.setdefault(v.tag, []).append((event.step, v.simple_value))
    return found


def test_seeds_tensorboard_and_resume(finished_run, tmp_path):
    """--seeds 0,3: one vmapped run; seed 0 equals the single run of seed 0; per-seed CSV and TensorBoard;
    --resume of the multi-seed run is exact."""
    pytest.importorskip("tensorboardX")
    out = str(tmp_path / "seeds")
    assert cli.main(TINY + ["--out", out, "--seeds", "0,3", "--tensorboard"]) == 0
    single, multi = _restore(finished_run), _restore_multi(out)
    for x, y in zip(jax.tree_util.tree_leaves(single.params), jax.tree_util.tree_leaves(multi.params)):
        np.testing.assert_allclose(np.asarray(x), np.asarray(y)[0], rtol=1e-4, atol=1e-5)
        assert np.asarray(y).shape[0] == 2
    assert not np.allclose(*np.asarray(jax.tree_util.tree_leaves(multi.params)[0]))
    for seed in (0, 3):
        with open(os.path.join(out, f"metrics-s{seed}.csv")) as f:
            assert [int(r["env_steps"]) for r in csv.DictReader(f)] == [2048, 4096]
        tb = _tb_scalars(os.path.join(out, "tb", f"s{seed}"))
        assert [step for step, _ in tb["eval_reward"]] == [2048, 4096] and "loss" in tb
    with open(os.path.join(finished_run, "metrics.csv")) as f, open(os.path.join(out, "metrics-s0.csv")) as g:
        a, b = list(csv.DictReader(f)), list(csv.DictReader(g))
    np.testing.assert_allclose([float(r["loss"]) for r in a], [float(r["loss"]) for r in b], rtol=1e-3)
    # resume after the first checkpoint ends where the uninterrupted multi-seed run did
    killed = str(tmp_path / "killed")
    shutil.copytree(out, killed)
    shutil.rmtree(os.path.join(killed, "checkpoints", "128"))
    assert cli.main(TINY + ["--out", killed, "--seeds", "0,3", "--resume"]) == 0
    for x, y in zip(jax.tree_util.tree_leaves(multi), jax.tree_util.tree_leaves(_restore_multi(killed))):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def _restore_multi(out):
    run = cli.Run(cli.build_parser().parse_args(TINY + ["--out", out, "--seeds", "0,3"]))
    state, _ = checkpoint.restore(run.ckpt_dir, run.trainer.init(run._keys()), run.metadata)
    return state


def test_tensorboard_without_tensorboardx_names_the_extra(tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "tensorboardX", None)  # import fails as if not installed
    _fails(capsys, TINY + ["--out", str(tmp_path / "tb"), "--tensorboard"], "jaxdc[tb]")


def test_a_checkpoint_of_the_older_metadata_format_resumes(tmp_path):
    """Format-1 metadata (learner options at their defaults and unset settings left out) is upgraded on resume."""
    out = str(tmp_path / "old")
    run = cli.Run(cli.build_parser().parse_args(TINY + ["--out", out]))
    old = {k: v for k, v in run.metadata.items() if k != "min_total_reward"}
    old["format"] = 1
    old["algorithm"] = {k: v for k, v in old["algorithm"].items() if k not in common.LEARNER_OPTIONS}
    checkpoint.save(run.ckpt_dir, 1, run.trainer.init(run.init_key()), old)
    assert cli.main(TINY + ["--out", out, "--resume"]) == 0
    assert checkpoint.steps(run.ckpt_dir)[-1] == 128


def test_config_json_of_a_run_retrains_it_exactly(finished_run, tmp_path):
    """`--config RUN/config.json` (settings_from_metadata, as parser defaults) trains the same run again: the same
    final parameters."""
    out = str(tmp_path / "again")
    assert cli.main(["--config", os.path.join(finished_run, "config.json"), "--eval-every", "2048",
                     "--eval-episodes", "20", "--no-progress", "--out", out]) == 0
    for x, y in zip(jax.tree_util.tree_leaves(_restore(finished_run).params),
                    jax.tree_util.tree_leaves(_restore(out).params)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_the_budget_row_is_recorded_and_retrained_by_config(tmp_path, capsys):
    """``--heuristic-rows 11`` (beyond the thesis: Safe-Budget's row) reaches ENN and the run's config.json;
    ``--config RUN`` trains the same parameters again, and the loader rebuilds the eleven-row head."""
    import json

    from jaxdc.dcp import learned

    argv = [*TINY, "--net", "enn", "--steps", "2048", "--heuristic-rows", "11"]
    first, again = str(tmp_path / "rows"), str(tmp_path / "again")
    assert cli.main([*argv, "--out", first]) == 0
    assert json.load(open(os.path.join(first, "config.json")))["heuristic_rows"] == 11
    assert cli.main(["--config", first, "--eval-every", "2048", "--eval-episodes", "20", "--no-progress",
                     "--out", again]) == 0
    nets = [learned.load(run) for run in (first, again)]
    assert nets[0].heuristic_rows == 11 and nets[0].params["params"]["head"]["weights"]["kernel"].shape[-1] == 99
    for x, y in zip(jax.tree_util.tree_leaves(nets[0].params), jax.tree_util.tree_leaves(nets[1].params)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_a_wider_body_is_recorded_and_retrained_by_config(finished_run, tmp_path, capsys):
    """``--body-features``/``--body-hidden`` (beyond the thesis) reach the network and the run's config.json;
    ``--config RUN`` trains the same parameters again, and the loader rebuilds the body from the metadata. A body
    on the linear learner, which has none, is a usage error naming the field."""
    import json

    from jaxdc.dcp import learned

    argv = [*TINY, "--net", "enn", "--steps", "2048", "--body-features", "8", "4", "--body-hidden", "16"]
    first, again = str(tmp_path / "wide"), str(tmp_path / "again")
    assert cli.main([*argv, "--out", first]) == 0
    meta = json.load(open(os.path.join(first, "config.json")))
    assert meta["body_features"] == [8, 4] and meta["body_hidden"] == 16
    assert cli.main(["--config", first, "--eval-every", "2048", "--eval-episodes", "20", "--no-progress",
                     "--out", again]) == 0
    nets = [learned.load(run) for run in (first, again)]
    assert nets[0].net.body_features == (8, 4) and nets[0].net.body_hidden == 16
    assert nets[0].params["params"]["body"]["Dense_0"]["kernel"].shape == (4 * 4 * 4, 16)
    for x, y in zip(jax.tree_util.tree_leaves(nets[0].params), jax.tree_util.tree_leaves(nets[1].params)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    thesis = json.load(open(os.path.join(finished_run, "config.json")))
    assert not {"body_features", "body_hidden"} & set(thesis)  # old runs' files unchanged
    capsys.readouterr()  # the runs' reports
    _fails(capsys, [*TINY, "--body-hidden", "16", "--out", str(tmp_path / "linear")],
           "body_hidden=16: network 'linear' has no convolutional body")
    assert "heuristic_rows" not in thesis  # the thesis' ten rows are not recorded
    _fails(capsys, [*TINY, "--heuristic-rows", "11", "--out", str(tmp_path / "linear11")],
           "heuristic_rows=11: network 'linear' reads no heuristics")
