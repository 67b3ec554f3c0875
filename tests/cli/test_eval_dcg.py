"""`python -m eval.dcg` (jaxdc.cli.eval_dcg): JSON output, clear errors, determinism, the figure and render
subcommands (tiny games)."""

from __future__ import annotations

import dataclasses
import json
import os

import jax
import pytest

from jaxdc import pretrained
from jaxdc.cli import eval_dcg as cli
from jaxdc.cli.eval_dcg_settings import FigureSettings, OptimumSettings, RenderSettings
from jaxdc.dcg.analysis.collector_eval import evaluate
from jaxdc.dcg.learned import init_params, make_network

EPISODES = "16"  # one value for every evaluation here: the compiled program is shared


def _meta(net, **kw):
    meta = {"net": net, "problem": "dcg", "grid_size": 3, "total_reward": 3,
            "strategies": ["patrol", "restricted", "with_fog"], "energy": 15.0, "max_steps": 12,
            "history": 0 if net == "vnn" else 2, "alpha": 0.001 if net == "emnn" else None, "steps": 1_000_000,
            "seed": 0}
    meta.update(kw)
    return meta


def _save(folder, name, net, grid=3, **meta):
    params = init_params(make_network(net, 2), grid, 0 if net == "vnn" else 2, jax.random.PRNGKey(7))
    return pretrained.save(os.path.join(folder, name + ".msgpack"), params, _meta(net, **meta))


@pytest.fixture(scope="module")
def nets(tmp_path_factory):
    folder = str(tmp_path_factory.mktemp("nets"))
    _save(folder, "omn_conn", "omn_conn")
    return folder


def _run(argv, capsys):
    assert cli.main(argv) == 0
    return capsys.readouterr()


def _error(argv, capsys) -> str:
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2
    return capsys.readouterr().err


def test_json_fields_and_types(nets, tmp_path, capsys):
    out = _run(["--checkpoint", os.path.join(nets, "omn_conn.msgpack"), "--episodes", EPISODES, "--json",
                "--out", str(tmp_path)], capsys).out
    r = json.loads(out)  # exactly one JSON object
    assert out.strip().count("\n") == 0
    for col in ("reward", "rpe", "energy", "steps"):
        assert set(r[col]) == {"mean", "sd"} and all(isinstance(v, float) for v in r[col].values())
    assert r["episodes"] == 16 and r["net"] == "omn_conn"
    assert isinstance(r["opponent_accuracy"], float) and 0 <= r["opponent_accuracy"] <= 1
    assert list(r["per_strategy"]) == ["patrol", "restricted", "with_fog"]
    assert sum(s["episodes"] for s in r["per_strategy"].values()) == 16
    assert r["setting"]["energy"] == 15.0 and r["setting"]["grid_size"] == 3
    written = [f for f in os.listdir(tmp_path) if f.endswith(".json")]
    assert written == ["eval_omn_conn_e15_standard_s0.json"]
    with open(tmp_path / written[0]) as f:
        assert json.load(f)["reward"] == r["reward"]


def test_same_seed_same_numbers(nets, tmp_path, capsys):
    argv = ["--checkpoint", os.path.join(nets, "omn_conn.msgpack"), "--episodes", EPISODES, "--json",
            "--out", str(tmp_path)]
    a = json.loads(_run(argv, capsys).out)
    b = json.loads(_run(argv, capsys).out)
    for r in (a, b):
        r.pop("seconds")
    assert a == b
    c = json.loads(_run(argv + ["--seed", "5"], capsys).out)
    assert (c["reward"], c["steps"]) != (a["reward"], a["steps"])


def test_figure_writes_png_json_and_claims(nets, tmp_path, capsys):
    out, img = tmp_path / "res", tmp_path / "img"
    argv = ["figure", "5.6", "--nets-dir", nets, "--episodes", EPISODES, "--out", str(out), "--img", str(img),
            "--cache", str(tmp_path / "cache"), "--bound-episodes", "8"]
    md = _run(argv, capsys).out
    assert sorted(os.listdir(img)) == ["dcg_fig5_6.png", "dcg_fig5_7.png", "dcg_standard_per_strategy.png"]
    assert all((img / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for f in os.listdir(img))
    with open(out / "figure_standard.json") as f:
        data = json.load(f)
    assert list(data["results"]["all"]) == ["OMN+CoNN"]
    assert data["results"]["all"]["OMN+CoNN"]["episodes"] == 16
    assert any("over 98%" in c["claim"] for c in data["claims"])
    assert any(m.startswith("VNN") for m in data["missing"])  # says which networks are missing
    assert (out / "figure_standard.csv").read_text().startswith("group,network,strategy")
    assert "| thesis claim | ours | agrees |" in md and "Missing networks" in md
    # the sampled full-information bound of the game is drawn and every bar gets its share of it
    bound = data["bounds"]["all"]
    assert bound["episodes"] == 8 and bound["total"] > 0 and set(bound["per_strategy"]) <= {"patrol", "restricted",
                                                                                            "with_fog"}
    assert data["results"]["all"]["OMN+CoNN"]["fraction_of_bound"] == pytest.approx(
        data["results"]["all"]["OMN+CoNN"]["reward"]["mean"] / bound["total"])
    # the evaluation (and the bound) are stored and reused: a second run reads them instead of playing again
    (stored,) = [f for f in os.listdir(tmp_path / "cache") if not f.startswith("bound_")]
    with open(tmp_path / "cache" / stored) as f:
        kept = json.load(f)
    kept["reward"]["mean"] = 123.0
    with open(tmp_path / "cache" / stored, "w") as f:
        json.dump(kept, f)
    _run(argv, capsys)
    with open(out / "figure_standard.json") as f:
        assert json.load(f)["results"]["all"]["OMN+CoNN"]["reward"]["mean"] == 123.0


def test_render_writes_strip_and_gif(nets, tmp_path, capsys):
    text = _run(["render", "--checkpoint", os.path.join(nets, "omn_conn.msgpack"), "--strategy", "patrol",
                 "--seed", "1", "--greedy", "--max-steps", "4", "--out", str(tmp_path)], capsys).out
    files = sorted(os.listdir(tmp_path))
    assert files == ["dcg_omn_conn_patrol_s1_greedy.gif", "dcg_omn_conn_patrol_s1_greedy.png"]
    assert (tmp_path / files[0]).read_bytes()[:4] == b"GIF8"
    assert "patrol" in text


@pytest.mark.parametrize("extra, message", [
    (["--strategies", "nope"], "unknown strategy 'nope'"),
    (["--strategies", ""], "must not be empty"),
    (["--energy", "0"], "--energy must be > 0"),
    (["--energy", "-3"], "--energy must be > 0"),
    (["--energy", "lots"], "--energy must be a number"),
    (["--episodes", "0"], "--episodes must be an integer >= 1"),
    (["--reward-area", "4"], "reward_area must be between 1 and grid_size (3)"),
    (["--strategies", "patrol", "--double-blind"], "not allowed with argument"),
])
def test_clear_errors_for_bad_settings(nets, capsys, extra, message):
    err = _error(["--checkpoint", os.path.join(nets, "omn_conn.msgpack"), "--episodes", EPISODES] + extra, capsys)
    assert message in err


def test_clear_errors_for_bad_files(nets, tmp_path, capsys):
    assert "not found" in _error(["--checkpoint", str(tmp_path / "nothing.msgpack")], capsys)
    assert "no orbax checkpoint" in _error(["--checkpoint", str(tmp_path)], capsys)
    assert "no shipped dcg parameters named 'nope'" in _error(["--net", "nope"], capsys)
    assert "one of the arguments --checkpoint --net is required" in _error([], capsys)
    # corrupt parameters
    bad = _save(str(tmp_path), "corrupt", "omn_conn")
    with open(bad, "wb") as f:
        f.write(b"\x00not msgpack")
    assert "corrupt or truncated" in _error(["--checkpoint", bad], capsys)
    # another network's parameters under this name
    other = _save(str(tmp_path), "liar", "omn_conn")
    with open(other[: -len(".msgpack")] + ".json", "w") as f:
        json.dump(_meta("imnn"), f)
    assert "not those of a imnn network" in _error(["--checkpoint", other], capsys)
    # the right network trained on another grid
    wide = _save(str(tmp_path), "wide", "omn_conn", grid=4)
    assert "has shape" in _error(["--checkpoint", wide], capsys)
    # a DCP file
    dcp = _save(str(tmp_path), "dcp", "omn_conn", problem="dcp")
    assert "not 'dcg'" in _error(["--checkpoint", dcp], capsys)
    # render takes one strategy
    assert "one strategy" in _error(["render", "--checkpoint", os.path.join(nets, "omn_conn.msgpack"),
                                     "--strategy", "patrol,restricted"], capsys)
    # figure: an empty folder says how to get networks
    empty = tmp_path / "empty"
    empty.mkdir()
    assert "no DCG parameter files" in _error(["figure", "5.6", "--nets-dir", str(empty)], capsys)


def test_a_train_dcg_run_folder_plays_like_its_exported_parameters(nets, tmp_path, capsys):
    """--checkpoint RUN_FOLDER restores the latest orbax checkpoint of train.dcg and evaluates its parameters."""
    from jaxdc import checkpoint
    from jaxdc.dcg import learned

    blob = os.path.join(nets, "omn_conn.msgpack")
    exported = learned.load(blob)
    meta = dict(_meta("omn_conn"), format=1, algorithm={"total_steps": 64, "num_envs": 2, "t_max": 4})
    meta.pop("steps")
    state = learned.train_state_template(exported.net, meta, "test").replace(params=exported.params)
    checkpoint.save(str(tmp_path / "run" / "checkpoints"), 16, state, meta)
    argv = ["--episodes", EPISODES, "--json", "--out", str(tmp_path)]
    from_run = json.loads(_run(["--checkpoint", str(tmp_path / "run")] + argv, capsys).out)
    from_file = json.loads(_run(["--checkpoint", blob] + argv, capsys).out)
    for key in ("reward", "rpe", "steps", "opponent_accuracy", "per_strategy"):
        assert from_run[key] == from_file[key]
    assert from_run["setting"]["trained_steps"] == 64


def test_shipped_one_item_network_nears_the_bound_and_beats_the_standard_one():
    """``omn_conn_area2`` (trained on one item in the 2 x 2 reward area, docs/dcg.md) against the standard
    OMN+CoNN on that game, both as fractions of the exact full-information bound."""
    from jaxdc.dcg import learned

    area, standard = (evaluate(learned.shipped(n), episodes=2000, seed=1, reward_area=2)
                      for n in ("omn_conn_area2", "omn_conn"))
    a, b = area["reward"], standard["reward"]
    se = ((a["sd"] ** 2 + b["sd"] ** 2) / 2000) ** 0.5
    assert a["mean"] - b["mean"] > 4 * se, (a, b)
    assert area["bound"]["total"] == standard["bound"]["total"] > a["mean"]
    assert area["fraction_of_bound"] > 0.85, area["fraction_of_bound"]  # 92.1% over 10,000 games


def test_a_command_line_without_subcommand_is_an_evaluation(nets, tmp_path, capsys):
    argv = ["--checkpoint", os.path.join(nets, "omn_conn.msgpack"), "--episodes", EPISODES, "--json",
            "--out", str(tmp_path)]
    implicit = json.loads(_run(argv, capsys).out)
    explicit = json.loads(_run(["evaluate"] + argv, capsys).out)
    assert implicit["command"] == "python -m eval.dcg " + " ".join(argv)
    assert explicit["command"] == "python -m eval.dcg evaluate " + " ".join(argv)
    for r in (implicit, explicit):
        r.pop("seconds"), r.pop("command")
    assert implicit == explicit
    with pytest.raises(SystemExit):
        cli.main(["--help"])
    assert capsys.readouterr().out.startswith("usage: python -m eval.dcg [-h] (--checkpoint PATH|NAME | --net NAME)")
    with pytest.raises(SystemExit):
        cli.main(["figure", "--help"])
    assert capsys.readouterr().out.startswith("usage: python -m eval.dcg figure [-h]")


def test_settings_are_settled_once():
    args = cli.build_parser().parse_args(["optimum", "--double-blind", "--energy", "10"])
    s = OptimumSettings.from_args(args)
    assert s.game["strategies"] == cli.DOUBLE_BLIND_STRATEGIES and s.energy == 10.0 and s.progress
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.energy = 5.0
    args = cli.build_parser().parse_args(["render", "--net", "vnn", "--strategy", "patrol,restricted"])
    with pytest.raises(ValueError, match="one strategy"):
        RenderSettings.from_args(args)
    args = cli.build_parser().parse_args(["figure", "all", "--no-cache", "--no-bound"])
    f = FigureSettings.from_args(args)
    assert f.experiments == tuple(cli.EXPERIMENTS) and not f.cache.reuse and not f.play.bound


def test_optimum_two_collectors(tmp_path, capsys):
    """``--collectors 2``: the same games as one collector, the team's exact optimum where it fits (never below
    one collector's), else the documented upper bound -- the JSON says which; the default stays one collector."""
    game = ["optimum", "--grid-size", "3", "--total-reward", "3", "--energy", "3", "--max-steps", "8",
            "--episodes", "12", "--no-progress", "--json", "--out", str(tmp_path)]
    assert cli.main(game) == 0
    one = json.loads(capsys.readouterr().out)
    assert "collectors" not in one["optimum"] and "kind" not in one["optimum"]
    assert cli.main(game + ["--collectors", "2"]) == 0
    two = json.loads(capsys.readouterr().out)
    assert two["optimum"]["kind"] == "exact" and two["optimum"]["collectors"] == 2
    assert two["optimum"]["mean"] >= one["optimum"]["mean"] and two["optimum"]["episodes"] == 12
    assert len(list(tmp_path.glob("optimum_*.json"))) == 2  # the team's record does not overwrite one collector's
    assert cli.main(["optimum", "--episodes", "3", "--collectors", "2", "--no-progress", "--json",
                     "--out", str(tmp_path)]) == 0
    std = json.loads(capsys.readouterr().out)["optimum"]
    assert std["kind"] == "upper_bound" and std["mean"] == 10.0 and std["largest_search"] > 2**26
