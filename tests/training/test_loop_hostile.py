"""Hostile runs of jaxdc.training.loop (through train.dcp / train.dcg): non-finite or damaged checkpoints, two runs
into one folder, damaged metrics, a full disk, and refusals on --resume that must come before the trainer build."""

from __future__ import annotations

import errno
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import orbax.checkpoint as ocp
import pytest

from jaxdc import checkpoint
from jaxdc.agents import a2c
from jaxdc.cli import train_dcg, train_dcp
from jaxdc.training.lock import LOCK_NAME
from tests.support.cli_checks import ROOT, checkout_env, refused, wait_for

# 8 updates of 4 envs x 8 steps on a 4x4 grid; evaluations and checkpoints at updates 4 and 8.
TINY = ["--net", "linear", "--grid-size", "4", "--total-reward", "6", "--energy", "4", "8", "--risk", "low",
        "--steps", "256", "--envs", "4", "--t-max", "8", "--eval-every", "128", "--eval-episodes", "8",
        "--no-progress"]


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("loop") / "tiny")
    assert train_dcp.main(TINY + ["--out", out]) == 0
    assert checkpoint.steps(os.path.join(out, "checkpoints")) == [4, 8]
    return out


def _copy(finished, tmp_path, name="run"):
    out = str(tmp_path / name)
    shutil.copytree(finished, out)
    return out


def _raw(out, step):
    """The stored state dict of checkpoint ``step`` of run ``out`` (numpy arrays, no checks)."""
    with checkpoint._manager(os.path.join(out, "checkpoints")) as m:
        return m.restore(step, args=ocp.args.Composite(state=ocp.args.StandardRestore())).state


def _leaves(tree):
    import jax

    return jax.tree_util.tree_flatten_with_path(tree)[0]


def _poison(out, step, part, monkeypatch):
    """Rewrite checkpoint ``step`` of ``out`` with one NaN in the first array under ``part`` (``"nu"``: Adam's
    second moments, ``"params"``), as a run without the finiteness checks would have saved it."""
    d = os.path.join(out, "checkpoints")
    tree, meta = _raw(out, step), checkpoint.read_metadata(d, step)
    path, leaf = next((p, x) for p, x in _leaves(tree) if part in jax_path(p) and np.ndim(x) > 0)
    leaf.reshape(-1)[0] = np.nan
    shutil.rmtree(os.path.join(d, str(step)))
    with monkeypatch.context() as m:
        m.setattr(checkpoint, "check_finite", lambda *a, **k: None)
        checkpoint.save(d, step, tree, meta)
    return jax_path(path)


def jax_path(path):
    import jax

    return jax.tree_util.keystr(path)


def _no_build(monkeypatch):
    """Fail the test if a run builds its trainer (the refusals below must come before)."""
    def build(*args, **kwargs):
        raise AssertionError("the trainer was built before the refusal")

    monkeypatch.setattr(a2c, "make_train", build)


@pytest.mark.parametrize("part", ["nu", "params"])
def test_a_nan_in_the_latest_checkpoint_is_refused_and_an_intact_step_resumes_exactly(finished, tmp_path,
                                                                                     monkeypatch, capsys, part):
    out = _copy(finished, tmp_path)
    where = _poison(out, 8, part, monkeypatch)
    assert part in where
    refused(train_dcp.main, TINY + ["--out", out, "--resume"], capsys, out, "step 8 is damaged", "1 NaN",
            "Intact checkpoints: steps [4]", "--resume --resume-step STEP", "--resume-step 4")
    assert checkpoint.steps(os.path.join(out, "checkpoints")) == [4, 8] and not os.path.exists(
        os.path.join(out, LOCK_NAME))
    assert train_dcp.main(TINY + ["--out", out, "--resume", "--resume-step", "4"]) == 0
    assert "deleted the later checkpoints [8]" in capsys.readouterr().err
    assert checkpoint.steps(os.path.join(out, "checkpoints")) == [4, 8]
    for (pa, a), (pb, b) in zip(_leaves(_raw(finished, 8)), _leaves(_raw(out, 8))):
        assert pa == pb
        np.testing.assert_array_equal(a, b)  # ends where the uninterrupted run ended
    with open(os.path.join(out, "metrics.csv")) as f, open(os.path.join(finished, "metrics.csv")) as g:
        assert [r.split(",")[1] for r in f] == [r.split(",")[1] for r in g]


def test_a_nan_state_stops_the_run_before_it_is_evaluated_or_saved(finished, tmp_path, monkeypatch, capsys):
    """Even a NaN that got past the restore (here: the checkpoint checks switched off) never reaches an
    evaluation or a checkpoint: the state is checked after each block of updates, not only the loss."""
    out = _copy(finished, tmp_path)
    shutil.rmtree(os.path.join(out, "checkpoints", "8"))
    _poison(out, 4, "nu", monkeypatch)
    monkeypatch.setattr(checkpoint, "check_finite", lambda *a, **k: None)
    evaluated = []
    monkeypatch.setattr(train_dcp.DCPRun, "evaluate", lambda self, p, k: evaluated.append(1) or [{}])
    argv = TINY + ["--out", out, "--resume", "--eval-every", "32"]  # one update per block: its loss is finite
    assert train_dcp.main(argv) == train_dcp.EXIT_NAN
    err = capsys.readouterr().err
    assert "the training state holds" in err and "/params/" in err and "between updates 4 and 5" in err
    assert "The last good checkpoint (update 4)" in err
    assert evaluated == [] and checkpoint.steps(os.path.join(out, "checkpoints")) == [4]


def test_resume_refusals_come_before_the_trainer_build(finished, tmp_path, monkeypatch, capsys):
    _no_build(monkeypatch)
    refused(train_dcp.main, TINY + ["--out", finished, "--resume", "--lr", "0.00010000001"], capsys,
            "algorithm.lr: checkpoint has 0.0001, this run has 0.00010000001")
    refused(train_dcp.main, TINY + ["--out", finished, "--resume", "--resume-step", "5"], capsys,
            "--resume-step 5", "holds no checkpoint 5 (its steps: [4, 8])")
    refused(train_dcp.main, TINY + ["--out", finished, "--resume-step", "4"], capsys,
            "--resume-step 4 applies only with --resume")
    refused(train_dcp.main, TINY + ["--out", str(tmp_path / "none"), "--resume"], capsys, "no checkpoint found")
    assert not (tmp_path / "none").exists()
    out = _copy(finished, tmp_path)
    with open(os.path.join(out, "metrics.csv"), "a") as f:
        f.write("1024,12,0.5")  # a truncated row
    refused(train_dcp.main, TINY + ["--out", out, "--resume"], capsys, os.path.join(out, "metrics.csv"), "line 4",
            "truncated")
    os.remove(os.path.join(out, "metrics.csv"))
    os.mkdir(os.path.join(out, "metrics.csv"))
    # the output-path check of the CLI (jaxdc.io) sees it first: a folder where the run writes its metrics file
    refused(train_dcp.main, TINY + ["--out", out, "--resume"], capsys, os.path.join(out, "metrics.csv"),
            "is a folder, not a file")
    assert sorted(os.listdir(out)) == sorted(os.listdir(finished))  # nothing written, the lock file removed


def test_a_dcg_resume_is_refused_before_the_build_too(tmp_path, monkeypatch, capsys):
    out = tmp_path / "dcg"
    dcg = ["--net", "vnn", "--grid-size", "3", "--total-reward", "3", "--strategies", "restricted", "--steps", "256",
           "--envs", "4", "--t-max", "8", "--eval-every", "256", "--eval-episodes", "8", "--no-progress"]
    _no_build(monkeypatch)
    refused(train_dcg.main, dcg + ["--out", str(out), "--resume"], capsys, "no checkpoint found")


def test_a_second_run_into_a_folder_in_use_is_refused_at_once(finished, tmp_path, monkeypatch, capsys):
    """Two runs into one folder: the second is refused before its build, naming the folder and the first's
    process; SIGTERM of the first releases the folder. The first is signalled once it trains (its first
    checkpoint is written): a signal that arrives during XLA's compile waits for the compile to end, which on
    a loaded two-core CI machine took over two minutes."""
    out = tmp_path / "busy"
    argv = [a for a in TINY]
    argv[argv.index("--steps") + 1] = "2000000"
    proc = subprocess.Popen([sys.executable, "-m", "train.dcp", *argv, "--out", str(out)], cwd=ROOT,
                            env=checkout_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert wait_for(lambda: (out / LOCK_NAME).exists() and (out / LOCK_NAME).read_text().strip(), 120)
        assert wait_for(lambda: any(p.name.isdigit() for p in (out / "checkpoints").glob("*")), 300), \
            proc.stderr.read() if proc.poll() is not None else "no checkpoint after 300 s"
        _no_build(monkeypatch)
        t0 = time.monotonic()
        refused(train_dcp.main, TINY + ["--out", str(out)], capsys, f"--out {out} is in use by another run "
                f"(process {proc.pid})")
        refused(train_dcp.main, TINY + ["--out", str(out), "--resume"], capsys, f"process {proc.pid}")
        assert time.monotonic() - t0 < 10
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert not (out / LOCK_NAME).exists()


def test_a_full_disk_at_a_checkpoint_is_one_line_and_leaves_no_partial_folder(tmp_path, monkeypatch, capsys):
    out = str(tmp_path / "full")

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(ocp.handlers.JsonCheckpointHandler, "_save_fn", full)
    refused(train_dcp.main, TINY + ["--out", out], capsys, "checkpoint 4 could not be written into",
            os.path.join(out, "checkpoints"), "No space left on device")
    assert os.listdir(os.path.join(out, "checkpoints")) == [] and not os.path.exists(os.path.join(out, LOCK_NAME))
    monkeypatch.undo()
    # a stale partial folder (a save killed midway) is cleared when the run starts again
    os.makedirs(os.path.join(out, "checkpoints", "4.orbax-checkpoint-tmp-1234", "state"))
    assert train_dcp.main(TINY + ["--out", out]) == 0
    assert sorted(os.listdir(os.path.join(out, "checkpoints"))) == ["4", "8"]


# -- one run per folder: a checkpoints/ linked into another run ----------------------------------------


def test_a_checkpoints_folder_linked_into_another_run_is_refused(finished, tmp_path, monkeypatch, capsys):
    """runD/checkpoints -> runC/checkpoints: the lock of runD does not cover runC, where a live run may train, so a
    resume into runD (which deletes the later checkpoints and writes new ones) and a fresh run are refused before
    any work, naming the link; runC is left as it was."""
    run_c = _copy(finished, tmp_path, "runC")
    run_d = tmp_path / "runD"
    run_d.mkdir()
    shutil.copy(os.path.join(run_c, "metrics.csv"), run_d / "metrics.csv")
    (run_d / "checkpoints").symlink_to(os.path.join(run_c, "checkpoints"))
    before = sorted(os.listdir(os.path.join(run_c, "checkpoints")))
    _no_build(monkeypatch)
    for extra in (["--resume", "--resume-step", "4"], ["--resume"], []):
        refused(train_dcp.main, TINY + ["--out", str(run_d), *extra], capsys, str(run_d / "checkpoints"),
                "outside the run folder", "lock")
    assert sorted(os.listdir(os.path.join(run_c, "checkpoints"))) == before == ["4", "8"]
    assert sorted(os.listdir(run_d)) == ["checkpoints", "metrics.csv"]


def test_a_checkpoints_link_inside_the_run_folder_is_fine(finished, tmp_path, capsys):
    """The rule is where the folder resolves: a checkpoints/ linked to a folder inside the run folder is covered by
    its lock and resumes (here: a finished run, nothing to train)."""
    out = _copy(finished, tmp_path)
    os.rename(os.path.join(out, "checkpoints"), os.path.join(out, "store"))
    os.symlink("store", os.path.join(out, "checkpoints"))
    assert train_dcp.main(TINY + ["--out", out, "--resume"]) == 0
    assert "already finished" in capsys.readouterr().err


def test_init_from_a_run_whose_latest_checkpoint_is_damaged_names_the_intact_steps(finished, tmp_path, monkeypatch,
                                                                                   capsys):
    """A run folder is read at its latest step (--init-from, eval --checkpoint): a damaged one is refused with the
    intact steps and how to continue from one, as --resume does."""
    out = _copy(finished, tmp_path)
    _poison(out, 8, "params", monkeypatch)
    refused(train_dcp.main, TINY + ["--out", str(tmp_path / "next"), "--init-from", out], capsys, "step 8",
            "Intact checkpoints: steps [4]", "--resume-step 4")
