"""`python -m eval.dcg` (jaxdc.cli.eval_dcg) and the DCG library behind it against hostile input: every bad value
is refused before any work with one line naming the flag (exit 2, no traceback), no JSON holds NaN or Infinity,
result files land as a set, and Ctrl-C exits 130 leaving nothing half-written."""

from __future__ import annotations

import json
import os
import signal
import time

import jax
import numpy as np
import pytest
from flax import serialization

from jaxdc import pretrained
from jaxdc.cli import eval_dcg as cli
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis.report import figure_csv, optimum_payload, report, result_name
from jaxdc.dcg.env import DCG
from jaxdc.dcg.exact.many_items import sampled_bound
from jaxdc.dcg.learned import init_params, make_network
from jaxdc.io import json_text
from jaxdc.viewer import bars
from tests.support.cli_checks import cli_process


def _refused(capsys, argv, *words):
    """``main(argv)`` exits 2 with one error line naming each of ``words`` and no traceback."""
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    line = err.strip().splitlines()[-1]
    assert "error:" in line
    for w in words:
        assert w in line, (w, line)
    return line


def _empty(folder):
    return not os.path.exists(folder) or not os.listdir(folder)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """A 3x3 VNN parameter file (cheap to load and play)."""
    folder = str(tmp_path_factory.mktemp("nets"))
    params = init_params(make_network("vnn", 2), 3, 0, jax.random.PRNGKey(7))
    meta = {"net": "vnn", "problem": "dcg", "grid_size": 3, "total_reward": 3,
            "strategies": ["patrol", "restricted", "with_fog"], "energy": 15.0, "max_steps": 12, "history": 0,
            "steps": 1000, "seed": 0}
    return pretrained.save(os.path.join(folder, "vnn.msgpack"), params, meta)


# -- numbers: non-finite, out of range, integer overflow ------------------------------------------------
@pytest.mark.parametrize("argv, words", [
    (["--net", "vnn", "--seed", "99999999999999999999"], ["--seed", "99999999999999999999"]),
    (["--net", "vnn", "--seed", "-1"], ["--seed", "-1"]),
    (["--net", "vnn", "--max-steps", "3000000000"], ["--max-steps", "3000000000", "2147483647"]),
    (["--net", "vnn", "--episodes", "1000000000000"], ["--episodes", "1000000000000"]),
    (["--net", "vnn", "--episodes", "0"], ["--episodes", ">= 1"]),
    (["--net", "vnn", "--energy", "nan"], ["--energy", "NaN"]),
    (["--net", "vnn", "--energy", "1e40"], ["--energy"]),
    (["--net", "vnn", "--energy", "1e9"], ["--energy", "16777216"]),
    (["--net", "vnn", "--energy", "-5"], ["--energy", "-5"]),
    (["--net", "vnn", "--reward-area", "0"], ["--reward-area", ">= 1"]),
    (["--net", "vnn", "--strategies", "patrol,nobody"], ["--strategies", "nobody"]),
    (["--net", "vnn", "--strategies", "patrol,patrol"], ["--strategies", "repeat"]),
    (["figure", "5.6", "--bound-episodes", "1e3"], ["--bound-episodes", "1e3"]),
    (["figure", "5.6", "--seed", "4294967296"], ["--seed", "4294967296"]),
    (["render", "--net", "vnn", "--strategy", "patrol", "--fps", "0"], ["--fps", "0"]),
    (["render", "--net", "vnn", "--strategy", "patrol", "--fps", "inf"], ["--fps", "inf"]),
    (["render", "--net", "vnn", "--strategy", "patrol", "--fps", "nan"], ["--fps", "nan"]),
    (["render", "--net", "vnn", "--strategy", "patrol", "--fps", "61"], ["--fps", "60"]),
    (["render", "--net", "vnn", "--strategy", "patrol", "--cols", "100000"], ["--cols", "1000"]),
    (["render", "--net", "vnn", "--strategy", "patrol,restricted"], ["--strategy", "one"]),
    (["optimum", "--grid-size", "0"], ["--grid-size", ">= 2"]),
    (["optimum", "--grid-size", "1"], ["--grid-size", ">= 2"]),
    (["optimum", "--grid-size", "200"], ["--grid-size", "<= 7"]),
    (["optimum", "--energy", "2.5"], ["--energy", "2.5"]),
    (["optimum", "--energy", "inf", "--max-steps", "3000000000"], ["--max-steps"]),
    (["optimum", "--seed", "99999999999999999999"], ["--seed"]),
    (["optimum", "--total-reward", "2000000000"], ["--total-reward", "1000"]),
    (["optimum", "--collectors", "0"], ["--collectors", ">= 1"]),
    (["optimum", "--collectors", "3"], ["--collectors", "<= 2"]),
    (["optimum", "--collectors", "two"], ["--collectors", "two"]),
    (["optimum", "--collectors", "2", "--fog-target", "any"], ["--fog-target", "any"]),
    (["render", "--net", "vnn", "--strategy", "patrol", "--max-steps", "100000"], ["--max-steps", "1000"]),
])
def test_bad_numbers_refused(capsys, tmp_path, argv, words):
    out = str(tmp_path / "out")
    _refused(capsys, argv + ["--out", out], *words)
    assert _empty(out)


def test_reward_area_larger_than_the_grid(capsys, tmp_path, tiny):
    out = str(tmp_path / "out")
    _refused(capsys, ["--checkpoint", tiny, "--reward-area", "4", "--episodes", "4", "--out", out], "reward_area", "4")
    assert _empty(out)


def test_episodes_beyond_memory_one_line(capsys, tmp_path, tiny):
    out = str(tmp_path / "out")
    assert cli.main(["--checkpoint", tiny, "--episodes", "2000000000", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "lower the number of episodes" in err.strip().splitlines()[-1]
    assert _empty(out)


def test_exact_bound_beyond_memory_refused_before_playing(capsys, tmp_path, tiny):
    out = str(tmp_path / "out")
    t0 = time.perf_counter()
    assert cli.main(["--checkpoint", tiny, "--reward-area", "2", "--energy", "16000000", "--episodes", "4",
                     "--out", out]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "lower the energy" in err.strip().splitlines()[-1]
    assert time.perf_counter() - t0 < 20 and _empty(out)


def test_sampled_bound_beyond_memory():
    env = DCG(grid_size=3, total_reward=2, history=1, obs_history=False)
    with pytest.raises(MemoryError, match="lower the number of games"):
        sampled_bound(env, env.make_params(energy=5.0, max_steps=5), jax.random.PRNGKey(0), 2_000_000_000)


# -- output locations checked before the work ---------------------------------------------------------
@pytest.mark.parametrize("sub, flag", [
    (["--net", "vnn"], "--out"),
    (["optimum"], "--out"),
    (["render", "--net", "vnn", "--strategy", "patrol"], "--out"),
    (["figure", "5.6"], "--out"),
    (["figure", "5.6"], "--img"),
    (["figure", "5.6"], "--cache"),
])
def test_output_under_a_file(capsys, tmp_path, sub, flag):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    t0 = time.perf_counter()
    _refused(capsys, sub + [flag, str(blocker / "sub")], flag, "is a file")
    assert time.perf_counter() - t0 < 5  # refused before loading or playing anything
    assert blocker.read_text() == "x" and sorted(os.listdir(tmp_path)) == ["file"]


def test_output_folder_read_only(capsys, read_only_folder):
    _refused(capsys, ["optimum", "--out", str(read_only_folder / "results")], "--out", "not writable")
    assert os.listdir(read_only_folder) == []


def test_missing_inputs(capsys, tmp_path):
    _refused(capsys, ["--checkpoint", str(tmp_path / "nope.msgpack"), "--out", str(tmp_path / "o")], "nope")
    _refused(capsys, ["figure", "5.6", "--nets-dir", str(tmp_path / "none"), "--out", str(tmp_path / "o"),
                      "--img", str(tmp_path / "i"), "--cache", str(tmp_path / "c")], "--nets-dir")
    assert sorted(os.listdir(tmp_path)) == []


# -- damaged network files ------------------------------------------------------------------------------
def test_network_with_nan_parameters_refused(capsys, tmp_path, tiny):
    bad = tmp_path / "bad.msgpack"
    with open(tiny, "rb") as f:
        tree = serialization.msgpack_restore(f.read())
    leaves, treedef = jax.tree_util.tree_flatten(tree)
    leaves[0] = np.full_like(leaves[0], np.nan)
    bad.write_bytes(serialization.msgpack_serialize(jax.tree_util.tree_unflatten(treedef, leaves)))
    (tmp_path / "bad.json").write_text(open(tiny[: -len(".msgpack")] + ".json").read())
    with pytest.raises(ValueError, match="NaN"):
        learned_lib.load(str(bad))
    out = str(tmp_path / "out")
    line = _refused(capsys, ["--checkpoint", str(bad), "--out", out], "bad", "NaN")
    assert "bad.msgpack" in line or "bad" in line
    assert _empty(out)


def test_check_finite_names_the_file():
    params = {"params": {"Dense_0": {"kernel": np.array([1.0, np.inf], np.float32)}}}
    with pytest.raises(ValueError, match=r"some\.msgpack.*Dense_0"):
        pretrained.check_finite(params, "some.msgpack")


# -- strict JSON and undefined statistics -----------------------------------------------------------------
def _result(rpe_defined: bool):
    stat = {"mean": 1.0, "sd": 0.5}
    undefined = {"mean": None, "sd": None, "undefined": "no episode consumed energy"}
    per = {"reward": stat, "energy": stat, "rpe": stat if rpe_defined else undefined, "episodes": 3,
           "outcomes": {"caught": 3}, "steps": stat, "opponent_accuracy": None}
    return {**per, "per_strategy": {"patrol": dict(per)}, "seconds": 0.1, "net": "vnn", "alpha": None,
            "source": "x", "setting": {"grid_size": 3, "total_reward": 3, "energy": "inf", "max_steps": 5,
                                       "strategies": ["patrol"], "reward_area": None, "history": 0,
                                       "trained_steps": 1},
            "seed": 0, "greedy": False}


def test_undefined_statistic_reported_as_dash_and_null():
    r = _result(rpe_defined=False)
    text = report(r)
    assert "RPE — (no episode consumed energy)" in text and "nan" not in text.lower()
    assert json.loads(json_text(r))["rpe"]["mean"] is None
    assert result_name(r) == "eval_vnn_einf_patrol_s0.json"
    rows = figure_csv({None: {"vnn": {**r, "file": "vnn", "note": ""}}}).splitlines()
    assert rows[1].split(",")[6:8] == ["", ""]  # rpe mean and sd: empty cells
    png = bars.bar_chart_png({None: {"vnn": r}}, [None], "rpe", "t")
    assert png[:4] == b"\x89PNG"


def test_optimum_payload_unlimited_energy_is_strict():
    env = DCG(grid_size=3, total_reward=2, history=1, obs_history=False)
    res = {"mean": 1.0, "se": 0.0, "sd": 0.0, "per_strategy": {}, "episodes": 1, "item_cells_mean": 1.0,
           "seconds": 0.0, "rewards": np.array([1.0])}
    out = optimum_payload(res, env, energy=float("inf"), max_steps=5, chase_tie="straight", seed=0, command="c")
    assert json.loads(json_text(out))["energy"] == "inf"


def test_evaluate_unlimited_energy_json_is_strict(capsys, tmp_path, tiny):
    out = tmp_path / "out"
    assert cli.main(["--checkpoint", tiny, "--energy", "inf", "--episodes", "4", "--json", "--out", str(out)]) == 0
    line = capsys.readouterr().out.strip()
    data = json.loads(line, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    assert data["setting"]["energy"] == "inf"
    (written,) = os.listdir(out)
    assert written == "eval_vnn_einf_standard_s0.json"
    json.loads((out / written).read_text(), parse_constant=lambda c: pytest.fail(c))


# -- interruption ----------------------------------------------------------------------------------------
def test_sigint_exits_130_leaving_nothing(tmp_path):
    out = tmp_path / "out"
    env = {**os.environ, "JAXDC_NO_CACHE": "1", "JAX_PLATFORMS": "cpu"}
    with cli_process(["eval.dcg", "optimum", "--episodes", "100000", "--no-progress", "--out", str(out)],
                     env=env) as proc:
        time.sleep(10)  # the games are being solved by now
        assert proc.poll() is None
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines() == ["python -m eval.dcg: interrupted"]
    assert _empty(out)


# -- an output that is an input -------------------------------------------------------------------------
@pytest.mark.parametrize("output, argv", [
    # a render's picture whose path is a symbolic link to the network's sidecar would overwrite it
    ("dcg_vnn_patrol_s0.png", ["render", "--strategy", "patrol"]),
    ("eval_vnn_e15_patrol_s0.json", ["--strategies", "patrol", "--episodes", "2"]),
    # ``energies`` names its table after the network, known once it is loaded: still refused before any game
    ("energies_vnn_s0.md", ["energies", "--energies", "3"]),
])
def test_an_output_over_its_checkpoint_refused(capsys, tmp_path, tiny, output, argv):
    sidecar = tiny[: -len(".msgpack")] + ".json"
    before = open(sidecar).read()
    out = tmp_path / "o"
    out.mkdir()
    (out / output).symlink_to(sidecar)
    _refused(capsys, argv + ["--checkpoint", tiny, "--out", str(out)], "--out file",
             "would overwrite the input --checkpoint")
    assert open(sidecar).read() == before


def test_figure_over_a_network_of_nets_dir_refused(capsys, tmp_path, tiny):
    nets = os.path.dirname(tiny)
    (tmp_path / "img").mkdir()
    (tmp_path / "img" / "dcg_fig5_6.png").symlink_to(tiny)
    _refused(capsys, ["figure", "5.6", "--nets-dir", nets, "--out", str(tmp_path / "o"), "--img",
                      str(tmp_path / "img"), "--cache", str(tmp_path / "c")], "would overwrite the input --nets-dir")


# -- a result file no write can create: refused before any game ---------------------------------------------
def _block(path, how, target=None):
    if how == "folder":
        os.makedirs(path)
    elif how == "dangling link":
        os.symlink(os.path.join(os.path.dirname(path), "nowhere", "x"), path)
    else:
        os.symlink(target, path)


def _no_play(monkeypatch):
    """Fail the test if a game is played or searched: the refusals below come before any."""
    def play(*args, **kwargs):
        raise AssertionError("a game was played before the refusal")

    for name in ("evaluate", "evaluate_learned_team", "play_episode"):
        monkeypatch.setattr(cli, name, play)
    monkeypatch.setattr(cli.optimum, "sampled_bound", play)
    monkeypatch.setattr(cli.optimum, "team_bound", play)


@pytest.mark.parametrize("name, argv", [
    ("eval_vnn_e15_standard_s0.json", []),
    ("eval_vnn_einf_standard_greedy_mask-reach_base_s0.json", ["--energy", "inf", "--greedy", "--mask",
                                                               "reach_base"]),
    ("team_vnn_k2_e15_standard_s0.json", ["--collectors", "2"]),
])
@pytest.mark.parametrize("how", ["folder", "dangling link", "link to the checkpoint"])
def test_evaluate_result_file_blocked_refused_before_playing(capsys, tmp_path, tiny, monkeypatch, name, argv, how):
    """The result's name is fixed by the network and the settings: a folder or a dangling link at it, or a link to
    the input checkpoint, is refused before any game is played (not after all of them)."""
    out = tmp_path / "o"
    out.mkdir()
    _block(str(out / name), how, tiny)
    _no_play(monkeypatch)
    before = open(tiny, "rb").read()
    _refused(capsys, ["--checkpoint", tiny, "--episodes", "3", "--out", str(out), *argv], "--out file", name)
    assert os.listdir(out) == [name] and open(tiny, "rb").read() == before


@pytest.mark.parametrize("argv", [["--energy", "7", "--greedy", "--strategies", "patrol"], ["--collectors", "2"],
                                  ["--reward-area", "1", "--no-bound", "--mask", "reach_base"]])
def test_evaluate_checks_the_file_it_writes(capsys, tmp_path, tiny, monkeypatch, argv):
    """The name checked before the games is the name the results give: one check, the file written."""
    checked = []
    real = cli.check_output_path
    monkeypatch.setattr(cli, "check_output_path", lambda path, *a: checked.append(path) or real(path, *a))
    out = tmp_path / "o"
    assert cli.main(["--checkpoint", tiny, "--episodes", "2", "--out", str(out), "--json", *argv]) == 0
    capsys.readouterr()
    assert len(checked) == 1 and os.listdir(out) == [os.path.basename(checked[0])]


OPTIMUM = ["optimum", "--episodes", "10", "--grid-size", "3", "--total-reward", "2", "--energy", "6", "--max-steps",
           "10", "--no-progress"]


@pytest.mark.parametrize("how", ["folder", "dangling link"])
def test_optimum_result_file_blocked_refused_before_the_search(capsys, tmp_path, monkeypatch, how):
    out = tmp_path / "o"
    out.mkdir()
    _block(str(out / "optimum_4f4770a9.json"), how)
    _no_play(monkeypatch)
    _refused(capsys, OPTIMUM + ["--out", str(out)], "--out file", "optimum_4f4770a9.json")
    assert os.listdir(out) == ["optimum_4f4770a9.json"]


@pytest.mark.parametrize("argv", [[], ["--collectors", "2", "--energy", "inf"]])
def test_optimum_checks_the_file_it_writes(capsys, tmp_path, argv):
    out = tmp_path / "o"
    args = cli.build_parser().parse_args(OPTIMUM + ["--episodes", "3", "--out", str(out), *argv])
    settings = cli.optimum.OptimumSettings.from_args(args)
    expected = cli.optimum.result_path(settings, DCG(**settings.game))
    assert cli.main(OPTIMUM + ["--episodes", "3", "--out", str(out), "--json", *argv]) == 0
    capsys.readouterr()
    assert os.listdir(out) == [os.path.basename(expected)]


def test_render_result_file_blocked_refused_before_playing(capsys, tmp_path, tiny, monkeypatch):
    out = tmp_path / "o"
    out.mkdir()
    (out / "dcg_vnn_patrol_s0.gif").mkdir()
    _no_play(monkeypatch)
    _refused(capsys, ["render", "--strategy", "patrol", "--checkpoint", tiny, "--out", str(out)], "--out file",
             "dcg_vnn_patrol_s0.gif", "is a folder")
