"""Hostile input for the DRP command line (eval.drp, jaxdc.cli.eval_drp): the figure, plan and gaps
subcommands, their outputs, and Ctrl-C.

Every bad value is refused before any work with a non-zero exit and one line naming the flag (or the file and
key), the value and the allowed range, without a traceback; no NaN or Infinity reaches a file or stdout; an
interruption leaves the old files or the complete new set.
"""

import json
import os
import signal
import subprocess
import time

import numpy as np
import pytest

from jaxdc.cli import eval_drp as cli
from jaxdc.core.validate import SEED_MAX
from jaxdc.drp.analysis import cache
from jaxdc.drp.analysis.summary import markdown_tables
from tests.support.cli_checks import cli_process, refused, strict_json


def _refused(argv, capsys, *needles, code=2):
    """``python -m eval.drp argv`` is refused naming every needle (:func:`cli_checks.refused`)."""
    return refused(cli.main, argv, capsys, *needles, code=code)


def _graph_file(tmp_path, **changes):
    d = {"base": [0, 0], "nodes": [[3, 4], [1, 2], [5, 5]], "rewards": [4, 5, 6], "psi": 0.99, "alpha": 10}
    d.update(changes)
    path = tmp_path / "g.json"
    path.write_text(json.dumps(d) if not isinstance(changes.get("_raw"), str) else changes["_raw"])
    return path


# ----------------------------------------------------------------------------- figure flags


@pytest.mark.parametrize("alphas, shown", [("nan,10", "nan"), ("-5,10", "-5"), ("inf", "inf"), ("10,x", "x"),
                                           ("1e300", "1e300"), ("", "")])
def test_figure_alphas_must_be_finite_robot_values(tmp_path, capsys, alphas, shown):
    err = _refused(["--out", str(tmp_path / "o"), "figure", "3.1", f"--alphas={alphas}"], capsys, "--alphas")
    assert "[0, 1e+09]" in err and repr(shown)[1:-1] in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("flag, value, needle", [
    ("--graphs", "99999999999999999999", "<= 1000000"), ("--graphs", "0", ">= 1"),
    ("--nodes", "1000000000000", "<= 32768"), ("--nodes", "-3", ">= 1"),
    ("--seed", "99999999999999999999", f"<= {SEED_MAX}"), ("--seed", "-1", ">= 0"),
    ("--workers", "1000000000000", "<= 64"), ("--workers", "0", ">= 1")])
def test_figure_counts_and_seeds_are_bounded(tmp_path, capsys, flag, value, needle):
    _refused(["--out", str(tmp_path / "o"), "figure", "3.1", flag, value], capsys, flag, value, needle)
    assert not (tmp_path / "o").exists()


def test_figure_last_graph_seed_must_stay_a_seed(tmp_path, capsys):
    _refused(["--out", str(tmp_path / "o"), "figure", "3.1", "--seed", str(SEED_MAX), "--graphs", "2"], capsys,
             "--seed", "--graphs", "seed + i", str(SEED_MAX))
    assert not (tmp_path / "o").exists()


def test_figure_too_big_for_memory_says_what_to_lower(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**30))
    _refused(["--out", str(tmp_path / "o"), "figure", "3.1", "--graphs", "100", "--nodes", "20000"], capsys,
             "--graphs 100 --nodes 20000", "lower --graphs or --nodes")
    assert not (tmp_path / "o").exists()


def test_figure_out_under_a_file_is_refused_before_work(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cache, "compute_experiment", lambda *a, **k: pytest.fail("work started"))
    (tmp_path / "file").write_text("x")
    _refused(["--out", str(tmp_path / "file" / "o"), "figure", "3.1", "--quick"], capsys, "--out", "is a file")
    assert os.listdir(tmp_path) == ["file"]


def test_figure_out_in_a_read_only_folder_is_refused_before_work(read_only_folder, capsys, monkeypatch):
    monkeypatch.setattr(cache, "compute_experiment", lambda *a, **k: pytest.fail("work started"))
    _refused(["--out", str(read_only_folder / "o"), "figure", "3.1", "--quick"], capsys, "--out", "not writable")
    assert os.listdir(read_only_folder) == []


# ----------------------------------------------------------------------------- figure outputs


def _fake_record(config, norm_zero=False, **_):
    """Stands in for :func:`jaxdc.drp.analysis.cache.compute_experiment`: every plan earns 2 (or 0)."""
    alphas = list(config.alphas)
    raw = {(c, b): np.full((config.graphs, len(alphas)), 0.0 if norm_zero else 2.0)
           for c in ("nc", "pgc") for b in ("gi", "ng", "tl", "osa", "gml", "lpg")}
    from jaxdc.drp.analysis.summary import experiment_record
    return experiment_record(config.as_dict(), raw, {"nc_gi": 1.0}, 1.5, alphas)


def test_figure_files_land_together_or_not_at_all(tmp_path, capsys, monkeypatch):
    import jaxdc.viewer.curves as curves

    monkeypatch.setattr(cache, "compute_experiment", _fake_record)
    out = tmp_path / "o"
    argv = ["--out", str(out), "figure", "3.1", "--quick", "--alphas", "0,10", "--quiet"]
    real = curves.draw_curves

    def interrupted(*a, **k):
        raise KeyboardInterrupt
    monkeypatch.setattr(curves, "draw_curves", interrupted)
    assert cli.main(argv) == 130
    err = capsys.readouterr().err
    assert err.strip() == "python -m eval.drp: interrupted" and "Traceback" not in err
    assert not out.exists() or os.listdir(out) == []  # the data JSON and CSV wait for the PNG
    monkeypatch.setattr(curves, "draw_curves", real)
    assert cli.main(argv) == 0
    names = sorted(os.listdir(out))
    assert [n.rsplit(".", 1)[1] for n in names] == ["csv", "json", "png"]
    strict_json(capsys.readouterr().out)
    strict_json((out / [n for n in names if n.endswith(".json")][0]).read_text())


def test_figure_undefined_normaliser_is_null_with_a_reason(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cache, "compute_experiment", lambda c, **k: _fake_record(c, norm_zero=True))
    out = tmp_path / "o"
    assert cli.main(["--out", str(out), "figure", "3.1", "--quick", "--alphas", "0,10", "--quiet"]) == 0
    capsys.readouterr()
    data = strict_json((out / next(n for n in os.listdir(out) if n.endswith(".json"))).read_text())
    assert data["normaliser"] is None
    assert all(r["mean"] is None and r["sd"] is None and "normaliser" in r["undefined"] for r in data["rows"])
    csv_text = (out / next(n for n in os.listdir(out) if n.endswith(".csv"))).read_text()
    assert "nan" not in csv_text.lower() and "inf" not in csv_text.lower()
    assert "–" in markdown_tables(data["rows"], [0, 10], ("gi", "ng"))


def test_figure_unreadable_stored_results_are_recomputed(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cache, "compute_experiment", _fake_record)
    out = tmp_path / "o"
    out.mkdir()
    s = cli.settle(cli.build_parser().parse_args(["--out", str(out), "figure", "3.1", "--quick", "--alphas", "0,10"]))
    (out / f"experiment_{s.experiment.tag}.json").write_text('{"config": ')
    assert cli.main(["--out", str(out), "figure", "3.1", "--quick", "--alphas", "0,10", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "cannot be read" in err and "recomputing" in err and "Traceback" not in err
    strict_json((out / f"experiment_{s.experiment.tag}.json").read_text())


# ----------------------------------------------------------------------------- plan


@pytest.mark.parametrize("changes, needles", [
    ({"nodes": [[1e300, 1e300], [1, 2], [5, 5]]}, ["nodes[0][0]", "1e+300", "1e+09"]),
    ({"rewards": [1e300, 5, 6]}, ["rewards[0]", "1e+300", "[0, 1e+09]"]),
    ({"rewards": [True, 5, 6]}, ["rewards[0]", "True"]),
    ({"alpha": 1e40}, ["alpha", "1e+40", "1e+09"]),
    ({"psi": 1e-300}, ["psi", "1e-300", "float32"]),
    ({"base": [0, float("nan")]}, ["base[1]", "finite"]),
    ({"_raw": '{"base": [0, 0], "nodes": [[1, 1]], "rewards": [1' + "0" * 400 + '], "psi": 0.9, "alpha": 1}'},
     ["rewards[0]", "401 digits"]),
    ({"_raw": '{"base": [0, 0], "nodes": [[1, Infinity]], "rewards": [1], "psi": 0.9, "alpha": 1}'},
     ["nodes[0][1]", "finite"]),
])
def test_plan_refuses_graphs_the_float32_planners_cannot_hold(tmp_path, capsys, changes, needles):
    path = _graph_file(tmp_path, **changes)
    out = tmp_path / "o"
    _refused(["--out", str(out), "plan", "--graph", str(path), "--json"], capsys, "--graph", *needles)
    assert not out.exists() or os.listdir(out) == []


def test_plan_draw_under_a_file_is_refused_before_work(tmp_path, capsys, monkeypatch):
    import jaxdc.drp.solve as solve

    monkeypatch.setattr(solve, "solve_instances", lambda *a, **k: pytest.fail("work started"))
    path = _graph_file(tmp_path)
    (tmp_path / "file").write_text("x")
    _refused(["--out", str(tmp_path / "o"), "plan", "--graph", str(path), "--draw", str(tmp_path / "file" / "p.png")],
             capsys, "--draw", "is a file")
    assert not (tmp_path / "o").exists()


def test_plan_graph_too_big_for_memory_says_what_to_lower(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", "1000")
    path = _graph_file(tmp_path, nodes=[[i, i] for i in range(20)], rewards=[1] * 20)
    _refused(["--out", str(tmp_path / "o"), "plan", "--graph", str(path)], capsys, "--graph", "20-node",
             "lower the number of nodes")
    assert not (tmp_path / "o").exists()


def test_plan_missing_graph_file_names_it(tmp_path, capsys):
    _refused(["--out", str(tmp_path / "o"), "plan", "--graph", str(tmp_path / "missing.json")], capsys,
             "--graph", "missing.json")


# ----------------------------------------------------------------------------- gaps


@pytest.mark.parametrize("flag, value, needle", [("--nodes", "20", "<= 9"), ("--size", "inf", "finite"),
                                                 ("--size", "0", "> 0"), ("--alphas", "nan", "[0, 1e+09]"),
                                                 ("--graphs", "1000000000000", "<= 1000000"),
                                                 ("--seed", "99999999999999999999", str(SEED_MAX))])
def test_gaps_flags_are_bounded(tmp_path, capsys, flag, value, needle):
    _refused(["--out", str(tmp_path / "o"), "gaps", f"{flag}={value}"], capsys, flag, needle)
    assert not (tmp_path / "o").exists()


# ----------------------------------------------------------------------------- Ctrl-C


def _interrupt_once_working(argv, group):
    """Start ``python -m eval.drp argv``, wait until its progress bar shows (the work has begun), send SIGINT
    (to its whole process group with ``group``); ``(returncode, stderr)``."""
    import threading

    env = {**os.environ, "JAXDC_NO_CACHE": "1"}
    chunks, seen = [], threading.Event()
    with cli_process(["eval.drp", *argv], env=env, stdout=subprocess.DEVNULL) as proc:

        def read():
            for chunk in iter(lambda: proc.stderr.read(1), ""):
                chunks.append(chunk)
                if chunk == "%":  # tqdm's first "0%|"
                    seen.set()
        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        assert seen.wait(120), "".join(chunks)
        time.sleep(1.5)
        (os.killpg if group else os.kill)(proc.pid, signal.SIGINT)
        proc.wait(timeout=60)
        reader.join(timeout=10)
    return proc.returncode, "".join(chunks)


def _check_interrupted(rc, stderr, out):
    if rc == 0:  # finished before the signal: the complete set is there
        assert len(os.listdir(out)) == 3
        return
    assert rc == 130, stderr
    assert "Traceback" not in stderr, stderr
    lines = [ln.strip() for ln in stderr.replace("\r", "\n").splitlines()
             if ln.strip() and "DRP rewards" not in ln and "resource_tracker" not in ln and "warnings.warn" not in ln]
    assert lines == ["python -m eval.drp: interrupted"], stderr
    names = sorted(os.listdir(out)) if out.exists() else []
    assert names == [] or [n.rsplit(".", 1)[1] for n in names] == ["csv", "json", "png"], names


def test_sigint_exits_130_with_one_line_and_a_consistent_folder(tmp_path):
    out = tmp_path / "o"
    rc, err = _interrupt_once_working(["--out", str(out), "figure", "3.1", "--graphs", "3", "--nodes", "40",
                                       "--workers", "1"], group=False)
    _check_interrupted(rc, err, out)


def test_ctrl_c_to_the_process_group_stops_the_worker_processes_quietly(tmp_path):
    """Ctrl-C in a terminal reaches every process of the group: the workers ignore it, the parent stops them."""
    out = tmp_path / "o"
    rc, err = _interrupt_once_working(["--out", str(out), "figure", "3.1", "--graphs", "3", "--nodes", "40",
                                       "--workers", "2"], group=True)
    _check_interrupted(rc, err, out)


# ----------------------------------------------------------------------------- an output that is an input


def test_plan_draw_over_the_graph_refused(tmp_path, capsys):
    """`plan --graph D/g.png --draw D/g.png` would replace the graph with the picture; a symbolic link to the graph
    and the plan's JSON over the graph are refused the same way."""
    graph = tmp_path / "g.png"
    graph.write_text(_graph_file(tmp_path).read_text())
    before = graph.read_text()
    _refused(["--out", str(tmp_path / "o"), "plan", "--graph", str(graph), "--draw", str(graph)], capsys,
             "--draw", "would overwrite the input --graph")
    (tmp_path / "link.png").symlink_to(graph)
    _refused(["--out", str(tmp_path / "o"), "plan", "--graph", str(graph), "--draw", str(tmp_path / "link.png")],
             capsys, "--draw", "would overwrite the input --graph")
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / "plan_g_gi_pgc.json").symlink_to(graph)  # the plan's JSON, a link to the graph
    _refused(["--out", str(tmp_path / "o"), "plan", "--graph", str(graph)], capsys, "--out file",
             "would overwrite the input --graph")
    assert graph.read_text() == before


# ----------------------------------------------------------------------------- a file no write can create


def _settings(argv):
    return cli.settle(cli.build_parser().parse_args(argv))


@pytest.mark.parametrize("which", [0, 1, 2])  # the experiment's JSON, its CSV, the figure's PNG
@pytest.mark.parametrize("how", ["folder", "dangling link"])
def test_figure_files_blocked_are_refused_before_work(tmp_path, capsys, monkeypatch, which, how):
    """Every file ``figure`` writes is checked before the experiment runs (not after it, with a traceback)."""
    monkeypatch.setattr(cache, "compute_experiment", lambda *a, **k: pytest.fail("work started"))
    out = tmp_path / "o"
    out.mkdir()
    argv = ["--out", str(out), "figure", "3.1", "--graphs", "2", "--nodes", "5", "--quiet", "--workers", "1"]
    path = cli.figure_paths(_settings(argv))[which]
    if how == "folder":
        os.mkdir(path)
    else:
        os.symlink(str(tmp_path / "nowhere" / "x"), path)
    _refused(argv, capsys, "--out file", os.path.basename(path))
    assert os.listdir(out) == [os.path.basename(path)]


@pytest.mark.parametrize("how", ["folder", "dangling link"])
def test_gaps_file_blocked_is_refused_before_work(tmp_path, capsys, monkeypatch, how):
    import jaxdc.drp.analysis.gaps as gaps

    monkeypatch.setattr(gaps, "optimality_gaps", lambda *a, **k: pytest.fail("work started"))
    out = tmp_path / "o"
    out.mkdir()
    path = out / "gaps_n3_g2.json"
    if how == "folder":
        path.mkdir()
    else:
        path.symlink_to(tmp_path / "nowhere" / "x")
    _refused(["--out", str(out), "gaps", "--graphs", "2", "--nodes", "3", "--quiet"], capsys, "--out file",
             "gaps_n3_g2.json")
    assert os.listdir(out) == ["gaps_n3_g2.json"]


def test_figure_and_gaps_write_the_files_checked(tmp_path, capsys, monkeypatch):
    """The names checked before the work are the names written."""
    monkeypatch.setattr(cache, "compute_experiment", _fake_record)
    out = tmp_path / "o"
    argv = ["--out", str(out), "figure", "3.1", "--graphs", "2", "--nodes", "5", "--quiet", "--workers", "1"]
    assert cli.main(argv) == 0
    assert sorted(os.listdir(out)) == sorted(os.path.basename(p) for p in cli.figure_paths(_settings(argv)))
    argv = ["--out", str(tmp_path / "g"), "gaps", "--graphs", "2", "--nodes", "3", "--quiet"]
    assert cli.main(argv) == 0
    capsys.readouterr()
    assert os.listdir(tmp_path / "g") == [os.path.basename(cli.gaps_path(_settings(argv)))]

