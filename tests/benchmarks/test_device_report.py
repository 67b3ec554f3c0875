"""benchmarks/device_report.py: its flags are checked before any timing, and a small run writes one table
(JSON + markdown, together) whose rows are the environment and training rows it was asked for."""

from __future__ import annotations

import json

import pytest

from benchmarks import device_report


@pytest.mark.parametrize("argv, needle", [
    (["--batch-sizes", "0"], "--batch-sizes"),
    (["--train-steps", "-3"], "--train-steps"),
    (["--learners", "dqn"], "--learners"),
    (["--budget-s", "x"], "--budget-s"),
])
def test_bad_flags_are_refused_before_any_timing(argv, needle, capsys, tmp_path):
    with pytest.raises(SystemExit) as e:
        device_report.main(argv + ["--small", "--out-dir", str(tmp_path)])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_unwritable_out_dir_is_refused(capsys, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(SystemExit):
        device_report.main(["--small", "--out-dir", str(blocker / "sub")])
    assert "--out-dir" in capsys.readouterr().err


def test_rows_past_the_budget_are_listed_as_skipped(tmp_path, capsys):
    result = device_report.main(["--small", "--budget-s", "0", "--out-dir", str(tmp_path)])
    assert result["rows"] == []
    assert result["skipped"] == ["jax_random B=64", "jax_batched B=64", "jax_dcg_random B=64", "jax_dcg_batched B=64",
                                 "enn a2c envs=8", "enn ppo envs=8"]
    assert "Skipped (past the time budget)" in (tmp_path / "device_report.md").read_text()


@pytest.mark.slow  # two compiles (a rollout and an update): 112 s on the busy 2-core machine it was written on
def test_small_run_writes_one_table(tmp_path, capsys):
    argv = ["--small", "--json", "--games", "dcp", "--learners", "a2c", "--net", "linear", "--batch-sizes", "16",
            "--out-dir", str(tmp_path)]
    result = device_report.main(argv)
    printed = json.loads(capsys.readouterr().out)
    stored = json.loads((tmp_path / "device_report.json").read_text())
    assert printed["rows"] == stored["rows"] == json.loads(json.dumps(result["rows"]))
    assert "provenance" in stored
    env, batched, train = stored["rows"]
    assert (env["kind"], env["impl"], env["batch"], env["env_steps"]) == ("env", "jax_random", 16, 16 * 4)
    assert (batched["impl"], batched["batch"], batched["env_steps"]) == ("jax_batched", 16, 16 * 4)
    assert (train["kind"], train["impl"], train["num_envs"]) == ("train", "jaxdc linear (a2c)", 8)
    assert train["env_steps"] == 8 * 32 * 2  # --small: two updates of 8 environments x t_max 32 per call
    for row in (env, batched, train):
        assert row["steps_per_s"] > 0 and row["compile_s"] >= 0 and row["seconds"] > 0
    assert abs(train["s_per_1M"] * train["steps_per_s"] - 1e6) < 1e-3
    md = (tmp_path / "device_report.md").read_text()
    assert "| env | jax_random | 16 |" in md and "| train | jaxdc linear (a2c) | 256 |" in md
