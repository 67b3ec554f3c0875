"""`python -m train.ship --export-only` (jaxdc.training.ship.export) checks everything it takes from a run folder
before writing (issue 31): a bad value of the run's metrics.csv is refused naming the file, the line and the
column (exit 2), nothing is written, and what it writes its own loader reads; a failed training names its log's
error line (a run folder locked by another run: the folder and the process)."""

from __future__ import annotations

import csv
import json
import os
import shutil

import pytest

from jaxdc import pretrained
from jaxdc.cli import train_dcp, train_ship
from jaxdc.dcp import learned as learned_lib
from jaxdc.training import ship
from tests.support.cli_checks import refused, tiny_run

# 64 updates of 2 envs x 8 steps on a 4x4 grid, one evaluation (the last row of metrics.csv).
TINY = ["--net", "linear", "--grid-size", "4", "--total-reward", "6", "--energy", "4", "8", "--risk", "low",
        "--steps", "1024", "--envs", "2", "--t-max", "8", "--eval-every", "1024", "--eval-episodes", "4",
        "--no-progress"]


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    return tiny_run(train_dcp.main, TINY, tmp_path_factory)


def _runs_with(finished_run, tmp_path, column=None, value=None):
    """A ``--runs`` folder holding a copy of the run as ``enn`` whose metrics.csv's last row has ``column=value``."""
    run = tmp_path / "runs" / "enn"
    shutil.copytree(finished_run, run)
    if column is not None:
        path = run / "metrics.csv"
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        rows[-1][rows[0].index(column)] = value
        with open(path, "w", newline="") as f:
            csv.writer(f).writerows(rows)
    return tmp_path / "runs"


def _export_only(runs, out):
    return ["--export-only", "--only", "enn", "--runs", str(runs), "--out", str(out)]


@pytest.mark.parametrize("column, value, needles", [
    ("env_steps", "-5", ["must be an int >= 1"]),
    ("env_steps", "0", ["must be an int >= 1"]),
    ("env_steps", "1e999", ["'1e999'", "must be an int >= 1"]),
    ("env_steps", "12.5", ["'12.5'", "must be an int >= 1"]),
    ("env_steps", "nan", ["'nan'", "must be an int >= 1"]),
    ("eval_reward", "abc", ["'abc' is not a number"]),
    ("eval_reward", "nan", ["'nan'", "must be a finite number"]),
    ("eval_energy", "inf", ["'inf'", "must be a finite number"]),
    ("eval_rpe", "-1e999", ["must be a finite number"]),
])
def test_a_bad_metrics_value_is_refused_naming_the_file_line_and_column(finished_run, tmp_path, capsys, column,
                                                                          value, needles):
    runs = _runs_with(finished_run, tmp_path, column, value)
    csv_path = str(runs / "enn" / "metrics.csv")
    with open(csv_path) as f:
        line = len([row for row in f.read().splitlines() if row])
    err = refused(train_ship.main, _export_only(runs, tmp_path / "out"), capsys,
                  csv_path, f"line {line}", f"column {column}", *needles, code=2)
    assert len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists() or not os.listdir(tmp_path / "out")
    with pytest.raises(ValueError, match=f"column {column}"):
        ship.export("enn", str(runs / "enn"), ["python", "-m", "train.dcp"], str(tmp_path / "out2"))
    assert not (tmp_path / "out2").exists()


def test_a_good_run_exports_what_the_loader_reads(finished_run, tmp_path, capsys):
    runs = _runs_with(finished_run, tmp_path)
    out = tmp_path / "out"
    assert train_ship.main(_export_only(runs, out)) == 0
    meta = pretrained.read_metadata(str(out / "enn.msgpack"))
    with open(runs / "enn" / "metrics.csv", newline="") as f:
        last = list(csv.DictReader(f))[-1]
    assert meta["steps"] == int(last["env_steps"]) >= 1
    assert meta["train_eval"]["eval_reward"] == float(last["eval_reward"])
    assert learned_lib.load(str(out / "enn.msgpack")).net_name == "linear"
    json.loads((out / "enn.json").read_text(), parse_constant=lambda c: pytest.fail(f"non-strict JSON {c}"))


def test_an_empty_steps_cell_falls_back_to_the_runs_total_steps(finished_run, tmp_path):
    runs = _runs_with(finished_run, tmp_path, "env_steps", "")
    _, meta = ship.export_metadata("enn", str(runs / "enn"), ["python", "-m", "train.dcp"])
    assert meta["steps"] == 1024


def test_a_failed_training_names_its_logs_error_line(tmp_path, monkeypatch, capsys):
    runs = tmp_path / "runs"
    line = (f"python -m train.dcp: error: --out {runs}/enn is in use by another run (process 4242); wait for it "
            "to end, stop it, or choose another --out")

    def failing(names, commands, where, jobs):
        os.makedirs(where, exist_ok=True)
        with open(os.path.join(where, "enn.log"), "w") as f:
            f.write("usage: python -m train.dcp [-h]\n                 [--net NET]\n" + line + "\n")
        return ["enn"]

    monkeypatch.setattr(train_ship, "train_all", failing)
    rc = train_ship.main(["--only", "enn", "--runs", str(runs), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 1
    assert line in err and "process 4242" in err and f"{runs}/enn" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    assert ship.failure_line(str(runs), "missing") is None
