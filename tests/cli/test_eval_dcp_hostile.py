"""Hostile input for the DCP evaluation command line (eval.dcp, jaxdc.cli.eval_dcp) and the DCP library
behind it (planners, risk maps, learned networks, rows, summaries).

Every bad value is refused before any work with a non-zero exit and one line naming the flag (or the file and
key), the value and the allowed range, without a traceback; no NaN or Infinity reaches a file or stdout; an
interruption leaves the old files or the complete new set.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import types

import jax
import numpy as np
import pytest
from flax import serialization

from jaxdc import pretrained
from jaxdc.cli import eval_dcp as cli
from jaxdc.dcp import learned as learned_lib
from jaxdc.dcp.analysis.risk_map import load_risk_map
from jaxdc.dcp.analysis.rows import Playing, check_drop_fits
from jaxdc.dcp.analysis.setting import Setting
from jaxdc.dcp.analysis.table_results import markdown_table
from jaxdc.dcp.evaluate import summarize
from jaxdc.dcp.planners import PlannerConfig
from tests.support.cli_checks import ROOT, cli_process, refused, strict_json


def _files(folder):
    return sorted(os.listdir(folder)) if os.path.isdir(folder) else []


_refused = refused


# ----------------------------------------------------------------------------- eval.dcp: numeric flags


@pytest.mark.parametrize("argv, needles", [
    (["--lpg-init", "nan"], ("--lpg-init", "nan")),
    (["--lpg-init=-inf"], ("--lpg-init", "-inf")),
    (["--energy", "1e40", "1e40"], ("--energy", "1e+40", "16777216")),
    (["--energy", "nan", "8"], ("--energy", "nan")),
    (["--energy", "9", "8"], ("--energy", "must not exceed")),
    (["--energy", "0", "8"], ("--energy", "> 0")),
    (["--grid-size", "0"], ("--grid-size", ">= 2", "got 0")),
    (["--grid-size", "1"], ("--grid-size", ">= 2", "got 1")),
    (["--seed", "99999999999999999999"], ("--seed", "4294967295")),
    (["--seed", "-1"], ("--seed", ">= 0")),
    (["--run-seed", "-1"], ("--run-seed", ">= 0")),
    (["--episodes", "0"], ("--episodes", ">= 1")),
    (["--episodes", "1000000000000"], ("--episodes", "2147483647")),
    (["--max-steps", "3000000000"], ("--max-steps", "2147483647")),
    (["--epsilon", "5"], ("--epsilon", "[0, 1]")),
    (["--epsilon", "nan"], ("--epsilon", "nan")),
    (["--total-reward", "2000000000"], ("--total-reward", "16777216")),
])
def test_dcp_flag_refused(argv, needles, capsys):
    _refused(cli.main, argv + ["--json"], capsys, *needles)


@pytest.mark.parametrize("argv, needles", [
    (["--greedy"], ("--greedy", "safe_reward")),
    (["--epsilon", "0.1"], ("--epsilon", "navigators")),
    (["--policy", "enn", "--epsilon", "0.1"], ("--epsilon", "enn")),
    (["--out", "somewhere"], ("--out", "only to --table")),
    (["--no-learned"], ("--no-learned", "only to --table")),
    (["--table", "4.8", "--no-learned", "--greedy"], ("--greedy", "--no-learned")),
])
def test_dcp_flag_without_effect_refused(argv, needles, capsys, tmp_path):
    _refused(cli.main, argv + ["--episodes", "5"], capsys, *needles)
    assert not os.path.exists("somewhere")


def test_dcp_grid_too_large_for_memory(capsys, monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**30))
    _refused(cli.main, ["--grid-size", "200", "--episodes", "50", "--json"], capsys, "200 x 200", "lower")


def test_dcp_episodes_too_many_for_memory(capsys, monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**30))
    _refused(cli.main, ["--episodes", "1000000000", "--json"], capsys, "1000000000 episodes", "lower")


def test_dcp_optimal_solver_too_large_for_memory(capsys, monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**30))
    _refused(cli.main, ["--policy", "optimal", "--total-reward", "1", "--energy", "4", "100000", "--episodes", "5",
                        "--json"], capsys, "maximum energy 100000", "lower")
    from jaxdc.dcp.exact.optimal import solve_single_item

    with pytest.raises(MemoryError, match="100x100"):
        solve_single_item(np.zeros((100, 100), np.float32), 16, 8)


def test_dcp_drop_memory_check_api(monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**30))
    with pytest.raises(MemoryError, match="total reward"):
        check_drop_fits(Setting(8, 2**24, "high", (8.0, 16.0), 1000), Playing(episodes=10_000))


def test_dcp_planner_config_refuses_nan():
    with pytest.raises(ValueError, match="lpg_init"):
        PlannerConfig(lpg_init=float("nan"))
    with pytest.raises(ValueError, match="tie_rtol"):
        PlannerConfig(tie_rtol=float("inf"))
    assert PlannerConfig(lpg_init=float("inf")).lpg_init == float("inf")  # Algorithm 7 as printed


# ----------------------------------------------------------------------------- eval.dcp: risk-map files


def _risk(tmp_path, name, value, cell=(1, 2), npy=True):
    r = np.full((5, 5), 0.05, np.float32)
    r[0, 0] = 0
    path = tmp_path / name
    if npy:
        arr = r.astype(object) if value is None else r
        if isinstance(value, np.ndarray):
            arr = value
        elif value is not None:
            arr = r.copy()
            arr[cell] = value
        np.save(path, arr)
    else:
        cells = r.tolist()
        cells[cell[0]][cell[1]] = value
        path.write_text(json.dumps(cells))  # json.dumps writes NaN for a float nan
    return str(path)


@pytest.mark.parametrize("name, value, npy, needles", [
    ("bool.npy", np.eye(5, dtype=bool)[::-1], True, ("boolean",)),
    ("nan.npy", np.nan, True, ("nan", "(1, 2)")),
    ("complex.npy", np.zeros((5, 5), complex), True, ("complex",)),
    ("true.json", True, False, ("boolean", "true", "(1, 2)")),
    ("nan.json", float("nan"), False, ("nan",)),
    ("inf.json", float("inf"), False, ("infinity",)),
    ("text.json", "0.5", False, ("not a number", "(1, 2)")),
    ("huge.json", 1e300, False, ("finite",)),
])
def test_dcp_risk_map_refused(tmp_path, capsys, name, value, npy, needles):
    path = _risk(tmp_path, name, value, npy=npy)
    _refused(cli.main, ["--risk-map", path, "--episodes", "5", "--json"], capsys, "--risk-map", name, *needles)
    with pytest.raises(ValueError, match="risk map"):
        load_risk_map(path)


def test_dcp_risk_map_folder_refused(tmp_path, capsys):
    _refused(cli.main, ["--risk-map", str(tmp_path), "--json"], capsys, "--risk-map", "folder")


# ----------------------------------------------------------------------------- eval.dcp: learned networks


def _diverged_file(tmp_path, value):
    params = learned_lib.init_params(learned_lib.make_network("linear"), 8, jax.random.PRNGKey(3))
    meta = {"net": "linear", "problem": "dcp", "grid_size": 8, "total_reward": 30, "risk": "high",
            "energy": [8, 16], "max_steps": 1000, "steps": 1, "seed": 3}
    blob = pretrained.save(tmp_path / "lin", params, meta)  # save refuses NaN: damage the file afterwards
    tree = jax.tree_util.tree_map(lambda x: np.asarray(x).copy(), params)
    jax.tree_util.tree_leaves(tree)[-1].flat[0] = value
    with open(blob, "wb") as f:
        f.write(serialization.msgpack_serialize(serialization.to_state_dict(tree)))
    return blob


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_dcp_diverged_network_file_refused(tmp_path, capsys, value):
    blob = _diverged_file(tmp_path, value)
    out = tmp_path / "out"
    _refused(cli.main, ["--policy", "linear", "--checkpoint", blob, "--episodes", "5", "--json"], capsys, blob,
             "nan or inf")
    _refused(cli.main, ["--table", "4.9", "--checkpoint", blob, "--episodes", "5", "--out", str(out)], capsys, blob)
    assert not out.exists()


def test_dcp_non_finite_params_api():
    net = learned_lib.make_network("linear")
    params = jax.tree_util.tree_map(lambda x: np.asarray(x) * np.nan, learned_lib.init_params(net, 8))
    with pytest.raises(ValueError, match="in memory.*NaN"):
        learned_lib.check_params("linear", net, params, 8, "in memory")


# ----------------------------------------------------------------------------- eval.dcp: output locations


def test_dcp_out_under_a_file_refused_before_work(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    t0 = time.perf_counter()
    _refused(cli.main, ["--table", "4.8", "--no-learned", "--out", str(blocker / "sub")], capsys, "--out", "is a file")
    _refused(cli.main, ["--table", "4.8", "--no-learned", "--out", str(blocker)], capsys, "--out", "not a folder")
    assert time.perf_counter() - t0 < 5  # nothing was evaluated
    assert _files(tmp_path) == ["file"]


def test_dcp_out_read_only_refused(read_only_folder, capsys):
    _refused(cli.main, ["--table", "4.8", "--no-learned", "--out", str(read_only_folder / "x")], capsys, "--out",
             "writable")
    assert os.listdir(read_only_folder) == []


# ----------------------------------------------------------------------------- eval.dcp: undefined statistics


def test_dcp_undefined_rpe_is_null_and_a_dash(tmp_path, capsys):
    path = _risk(tmp_path, "m5.npy", 0.05)
    argv = ["--policy", "safe_neither", "--risk-map", path, "--energy", "1", "1", "--start", "base",
            "--episodes", "50"]
    assert cli.main(argv + ["--json"]) == 0
    out = capsys.readouterr().out
    obj = strict_json(out)
    assert obj["rpe"] == {"mean": None, "sd": None, "undefined": "no episode consumed energy"}
    assert cli.main(argv) == 0
    table = capsys.readouterr().out
    assert "nan" not in table.lower() and "| — | — |" in table


def test_dcp_summarize_empty_rpe_api():
    final = types.SimpleNamespace(ep_reward=np.array([1.0, 0.0]), ep_energy=np.zeros(2), outcome=np.array([4, 4]),
                                  time=np.array([1, 2]))
    s = summarize(final)
    assert s["rpe"]["mean"] is None and s["rpe"]["undefined"]
    strict_json(json.dumps(s))
    assert "—" in markdown_table(None, {"p": s})


# ----------------------------------------------------------------------------- eval.dcp: subprocesses


def test_dcp_subprocess_error_is_one_line():
    r = subprocess.run([sys.executable, "-m", "eval.dcp", "--lpg-init", "nan"], cwd=ROOT, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr and "--lpg-init" in r.stderr
    assert r.stderr.strip().splitlines()[-1].startswith("python -m eval.dcp: error:")


def test_dcp_sigint_exits_130_and_leaves_no_partial_set(tmp_path):
    out = tmp_path / "out"
    with cli_process(["eval.dcp", "--table", "4.3", "--no-learned", "--episodes", "500000", "--out", str(out)],
                     env=dict(os.environ, JAXDC_NO_CACHE="1")) as p:
        first = p.stderr.readline()  # "Evaluating Table 4.3 ...": the modules are loaded, the work starts
        assert first.startswith("Evaluating"), first
        time.sleep(3)
        p.send_signal(signal.SIGINT)
        stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == 130, stderr
    assert "Traceback" not in stderr
    assert stderr.strip().splitlines()[-1] == "python -m eval.dcp: interrupted"
    assert _files(out) in ([], ["table_4.3.json", "table_4.3.md"])


# ----------------------------------------------------------------------------- an output that is an input


def _copy_shipped(folder, stem):
    import shutil

    folder.mkdir(exist_ok=True)
    src = pretrained.shipped("dcp", "enn")
    shutil.copy(src, folder / f"{stem}.msgpack")
    shutil.copy(src[: -len(".msgpack")] + ".json", folder / f"{stem}.json")
    return folder / f"{stem}.msgpack"


def test_dcp_table_over_its_checkpoint_sidecar_refused(tmp_path, capsys):
    """`--table 4.3 --checkpoint D/table_4.3.msgpack --out D` would replace the checkpoint's sidecar with the
    table's JSON; an --out folder that is a symbolic link to D is refused the same way."""
    blob = _copy_shipped(tmp_path / "D", "table_4.3")
    sidecar = (tmp_path / "D" / "table_4.3.json").read_text()
    for out in (tmp_path / "D", tmp_path / "link"):
        if out.name == "link":
            out.symlink_to(tmp_path / "D")
        refused(cli.main, ["--table", "4.3", "--checkpoint", str(blob), "--out", str(out), "--episodes", "2"],
                capsys, "--out file", "table_4.3.json", "would overwrite the input --checkpoint")
    assert (tmp_path / "D" / "table_4.3.json").read_text() == sidecar


def test_dcp_generalisation_over_its_checkpoint_refused(tmp_path, capsys):
    blob = _copy_shipped(tmp_path / "D", "generalisation")
    refused(cli.main, ["generalisation", "--checkpoint", str(blob), "--out", str(tmp_path / "D")], capsys,
            "generalisation.json", "would overwrite the input --checkpoint")


def test_run_seed_without_a_checkpoint_refused(capsys):
    refused(cli.main, ["--policy", "enn", "--run-seed", "2", "--episodes", "4"], capsys,
            "--run-seed 2 needs --checkpoint (a train.dcp --seeds run folder)")


@pytest.mark.parametrize("count, needles", [
    ("0", ("--maps-per-source", ">= 1")),
    ("100000000", ("--maps-per-source", "1048576", "100000000")),
])
def test_generalisation_maps_per_source_refused_by_flag(count, needles, capsys):
    """The map count is refused by its flag, at the command line, not by the library's ``SeedSet.count``."""
    refused(cli.main, ["generalisation", "--checkpoint", "enn_general", "--maps-per-source", count], capsys, *needles)
