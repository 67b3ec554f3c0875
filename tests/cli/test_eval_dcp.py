"""Batched evaluation (jaxdc.dcp.evaluate), the evaluation setting and table results, the Table 4.8
reproduction check, and the eval.dcp CLI (jaxdc.cli.eval_dcp)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import types

import jax
import numpy as np
import pytest

from jaxdc.cli import eval_dcp as cli
from jaxdc.dcp.analysis.risk_map import load_risk_map
from jaxdc.dcp.analysis.rows import Playing, evaluate_rows, table_policies
from jaxdc.dcp.analysis.setting import EnvOptions, Setting, evaluation_setting, make_env
from jaxdc.dcp.analysis.table_learner import check_learner
from jaxdc.dcp.analysis.table_results import markdown_table, table_markdown_file, table_payload
from jaxdc.dcp.analysis.tables import TABLES, incr_rows
from jaxdc.dcp.env import DCP
from jaxdc.dcp.evaluate import evaluate_heuristic, summarize

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENV = DCP(grid_size=5, total_reward=6, idle_terminates=True)
PARAMS = ENV.make_params("high", (8.0, 16.0))


def test_evaluate_deterministic_by_seed():
    a = evaluate_heuristic(ENV, PARAMS, "safe_neither", jax.random.PRNGKey(0), 64)
    b = evaluate_heuristic(ENV, PARAMS, "safe_neither", jax.random.PRNGKey(0), 64)
    c = evaluate_heuristic(ENV, PARAMS, "safe_neither", jax.random.PRNGKey(1), 64)
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    assert not np.array_equal(np.asarray(a.ep_reward), np.asarray(c.ep_reward)) or not np.array_equal(
        np.asarray(a.ep_energy), np.asarray(c.ep_energy))
    assert np.all(np.asarray(a.outcome) != 0)  # every episode ended
    with pytest.raises(ValueError, match="policy"):
        evaluate_heuristic(ENV, PARAMS, "nope", jax.random.PRNGKey(0), 4)
    with pytest.raises(ValueError, match="episodes"):
        evaluate_heuristic(ENV, PARAMS, "safe_neither", jax.random.PRNGKey(0), 0)


def test_summarize_rpe_conventions():
    batch = types.SimpleNamespace(
        ep_reward=np.array([2.0, 1.0, 3.0, 0.0]),
        ep_energy=np.array([4, 0, 2, 5]),
        outcome=np.array([1, 3, 2, 1]),
        time=np.array([4, 1, 2, 5]),
    )
    ex = summarize(batch, "exclude")
    assert ex["reward"]["mean"] == pytest.approx(1.5) and ex["reward"]["sd"] == pytest.approx(math.sqrt(1.25))
    assert ex["energy"]["mean"] == pytest.approx(11 / 4)
    assert ex["rpe"]["mean"] == pytest.approx((0.5 + 1.5 + 0.0) / 3)
    assert ex["rpe"]["sd"] == pytest.approx(np.std([0.5, 1.5, 0.0]))
    zero = summarize(batch, "zero")
    assert zero["rpe"]["mean"] == pytest.approx(0.5)
    assert ex["episodes"] == 4
    assert ex["outcomes"] == {"risk": 2, "energy": 1, "cleared": 1, "idle": 0, "truncated": 0}
    with pytest.raises(ValueError, match="rpe_zero"):
        summarize(batch, "drop")


def test_table_4_8_safe_neither_reproduction():
    env = DCP(total_reward=1, idle_terminates=True)
    params = env.make_params("high", (8.0, 16.0))
    m = 4000
    final = evaluate_heuristic(env, params, "safe_neither", jax.random.PRNGKey(0), m)
    reward = np.asarray(final.ep_reward)
    mean = reward.mean()
    se = math.sqrt(0.55 * 0.45 / m)
    assert abs(mean - 0.55) < 4 * se, f"Safe-Neither reward {mean:.4f}, thesis 0.55 (4 SE = {4 * se:.4f})"


# ----------------------------------------------------------------------------------------------
# The evaluation setting, the rows and the written results
# ----------------------------------------------------------------------------------------------

class _FakeLearned:
    """Stands in for a jaxdc.dcp.learned.Learned: only what the setting and the results read."""

    net_name = "enn"
    source = "fake.msgpack"
    observation = "thesis"
    metadata = {"steps": 5, "seed": 2, "command": "python -m train.dcp"}

    def __init__(self, **setting):
        self._setting = {"grid_size": 6, "total_reward": 12, "risk": "low", "energy": [4, 9], "max_steps": 50,
                         **setting}

    def setting(self):
        return dict(self._setting)

    def env_options(self):
        return {"start": "base"}


def test_evaluation_setting_precedence():
    assert evaluation_setting() == Setting(8, 30, "high", (8.0, 16.0), 1000)
    # given values beat the learned network's, which beat the defaults
    got = evaluation_setting(None, _FakeLearned(), total_reward=7, max_steps=20)
    assert got == Setting(6, 7, "low", (4.0, 9.0), 20)
    # a table fixes risk, total reward and energy; given ones do not count
    spec = TABLES["4.7"]
    got = evaluation_setting(spec, None, risk="low", total_reward=3, energy=(1, 2), grid_size=5)
    assert got == Setting(5, 30, "high", (16.0, 32.0), 1000)
    assert isinstance(got.energy, tuple) and all(type(e) is float for e in got.energy)
    with pytest.raises(ValueError, match="trained on a 6x6 grid; it cannot play a 8x8"):
        evaluation_setting(None, _FakeLearned(), grid_size=8)


def test_evaluation_setting_risk_map_gives_grid_size():
    r = np.zeros((5, 5), np.float32)
    got = evaluation_setting(risk_map=r)
    assert got.grid_size == 5 and got.risk is r
    assert evaluation_setting(risk_map=r, grid_size=4).grid_size == 4


def test_env_options_and_make_env():
    opts = EnvOptions(start="base", items_on_base=False, idle_terminates=True)
    assert opts.kwargs()["idle_terminates"] and not opts.kwargs()["items_on_base"]
    learned = opts.kwargs(_FakeLearned())
    assert learned["idle_terminates"] is False and learned["start"] == "base"
    env, params = make_env(Setting(5, 6, "high", (8.0, 16.0), 77), opts)
    assert (env.grid_size, env.total_reward, env.start, env.items_on_base) == (5, 6, "base", False)
    assert int(params.max_steps) == 77


def test_load_risk_map_names_the_input(tmp_path):
    r = np.full((4, 4), 0.1, np.float32)
    r[0, 0] = 0
    (tmp_path / "m.json").write_text(json.dumps(r.tolist()))
    np.testing.assert_allclose(load_risk_map(str(tmp_path / "m.json")), r)
    with pytest.raises(ValueError, match="^risk map: no such file"):
        load_risk_map(str(tmp_path / "nope.npy"))
    with pytest.raises(ValueError, match="^--risk-map: no such file"):
        load_risk_map(str(tmp_path / "nope.npy"), "--risk-map")


def test_rows_are_the_table_policies_played_alike():
    spec = TABLES["4.8"]
    assert table_policies(spec) == spec.heuristic_rows
    assert table_policies(spec, _FakeLearned()) == spec.heuristic_rows + ("enn",)
    setting, playing = Setting(5, 6, "high", (8.0, 16.0), 1000), Playing(episodes=32, seed=4)
    seen = []
    rows = evaluate_rows(("safe_neither", "safe_reward"), setting, EnvOptions(), playing,
                         progress=lambda name, s: seen.append(name))
    assert list(rows) == seen == ["safe_neither", "safe_reward"]
    env, params = make_env(setting)
    direct = summarize(evaluate_heuristic(env, params, "safe_neither", jax.random.PRNGKey(4), 32))
    assert {k: v for k, v in rows["safe_neither"].items() if k != "seconds"} == direct
    assert rows["safe_neither"]["seconds"] >= 0


def test_check_learner_against_the_table_setting():
    learned = _FakeLearned(risk="high", energy=[8, 16])
    assert check_learner(TABLES["4.3"], learned) is learned
    with pytest.raises(ValueError, match="Table 4.7 needs a enn trained with risk 'high' and energy 16/32; "
                                         "this one was trained with risk 'high' and energy 8/16"):
        check_learner(TABLES["4.7"], learned)


def test_table_results_markdown_and_payload():
    spec = TABLES["4.3"]
    row = {"reward": {"mean": 10.0, "sd": 1.0}, "energy": {"mean": 20.0, "sd": 2.0},
           "rpe": {"mean": 0.5, "sd": 0.1}, "episodes": 3, "outcomes": {"risk": 2, "energy": 0, "cleared": 1}}
    rows = {**{nav: row for nav in spec.heuristic_rows}, "enn": dict(row, reward={"mean": 12.0, "sd": 1.0})}
    incr = incr_rows(spec, rows, "enn")
    assert incr["safe_reward"]["reward"][1] == pytest.approx(20.0)
    assert incr["safe_reward"]["reward"][0] == pytest.approx(100 * (13.16 - 11.55) / 11.55)
    assert incr_rows(spec, rows, None) == {} and incr_rows(spec, rows, "eqn") == {}
    md = markdown_table(spec, rows, incr).splitlines()
    assert md[2] == ("| safe_reward | 11.55 ± 6.38 | 10.00 ± 1.00 | 29.65 ± 19.75 | 20.00 ± 2.00 | 0.495 ± 0.301 "
                     "| 0.500 ± 0.100 | risk 2, cleared 1 |")
    assert md[8].startswith("| incr.% over |") and md[10].startswith("| safe_reward | 13.94 | 20.00 |")
    assert markdown_table(None, {"lpg": row}).splitlines()[2].startswith("| lpg | — | 10.00 ± 1.00 | — |")
    assert table_markdown_file(spec, "python -m eval.dcp --table 4.3", "T") == (
        f"### Table 4.3: {spec.caption}\n\n`python -m eval.dcp --table 4.3`\n\nT\n")
    payload = table_payload(spec, "cmd", rows, incr, _FakeLearned())
    assert list(payload) == ["table", "caption", "command", "thesis", "ours", "incr", "learned", "best"]
    assert payload["thesis"]["enn"] == list(spec.rows["enn"])
    assert payload["best"] is None
    assert payload["learned"] == {"net": "enn", "row": "enn", "source": "fake.msgpack",
                                  "trained": _FakeLearned().setting(),
                                  "steps": 5, "seed": 2, "command": "python -m train.dcp"}
    assert table_payload(spec, "cmd", rows, {}, None)["learned"] is None


# ----------------------------------------------------------------------------------------------
# CLI
# ----------------------------------------------------------------------------------------------

KEYS = {"reward", "energy", "rpe", "episodes", "outcomes"}


def test_cli_json_in_process(capsys):
    assert cli.main(["--policy", "safe_neither", "--episodes", "200", "--json", "--grid-size", "5",
                     "--total-reward", "6"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1
    obj = json.loads(out)
    assert KEYS <= set(obj) and obj["episodes"] == 200
    assert sum(obj["outcomes"].values()) == 200


def test_cli_json_subprocess():
    r = subprocess.run([sys.executable, "-m", "eval.dcp", "--policy", "safe_neither", "--episodes", "200", "--json",
                        "--grid-size", "5", "--total-reward", "6"],
                       cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stdout.splitlines() if ln.strip()]
    assert len(lines) == 1
    obj = json.loads(lines[0])
    assert KEYS <= set(obj) and obj["episodes"] == 200


@pytest.mark.parametrize(
    "argv, word",
    [
        (["--episodes", "0"], "--episodes"),
        (["--energy", "-1", "5"], "energy"),
        (["--energy", "9", "8"], "energy"),
        (["--risk", "extreme"], "--risk"),
        (["--policy", "nope"], "--policy"),
    ],
)
def test_cli_bad_args_exit_2(argv, word, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(argv + ["--json"])
    assert e.value.code == 2
    assert word in capsys.readouterr().err


def test_cli_bad_risk_map_file(tmp_path, capsys):
    bad = tmp_path / "bad.npy"
    np.save(bad, np.full((5, 5), 0.5, np.float32))  # base risk != 0
    for path in (str(bad), str(tmp_path / "missing.npy")):
        with pytest.raises(SystemExit) as e:
            cli.main(["--risk-map", path, "--episodes", "10", "--json"])
        assert e.value.code == 2
        assert "--risk-map" in capsys.readouterr().err
    garbage = tmp_path / "g.json"
    garbage.write_text("{not json")
    with pytest.raises(SystemExit) as e:
        cli.main(["--risk-map", str(garbage), "--episodes", "10", "--json"])
    assert e.value.code == 2 and "--risk-map" in capsys.readouterr().err


def test_cli_risk_map_file_works(tmp_path, capsys):
    r = np.full((5, 5), 0.05, np.float32)
    r[0, 0] = 0
    f = tmp_path / "map.npy"
    np.save(f, r)
    assert cli.main(["--risk-map", str(f), "--policy", "safe_neither", "--episodes", "50", "--total-reward", "6",
                     "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["episodes"] == 50 and KEYS <= set(obj)


def test_cli_table_4_8_writes_results(tmp_path, capsys):
    assert cli.main(["--table", "4.8", "--episodes", "300", "--out", str(tmp_path), "--no-learned"]) == 0
    js, md = tmp_path / "table_4.8.json", tmp_path / "table_4.8.md"
    assert js.exists() and md.exists()
    data = json.loads(js.read_text())
    assert {"thesis", "ours"} <= set(data)
    # the navigators, then (beyond the thesis, a single-item table) the exact optimum of value iteration
    assert list(data["ours"]) == ["safe_reward", "safe_recharge", "safe_both", "safe_neither", "optimal"]
    opt = data["ours"]["optimal"]
    assert opt["reward"]["mean"] == pytest.approx(opt["expected_optimum"], abs=4 * 0.5 / 300 ** 0.5)
    assert all(opt["expected_optimum"] >= v["reward"]["mean"] - 0.1 for v in data["ours"].values())
    assert data["thesis"]["safe_neither"][0] == 0.55
    assert all(v["episodes"] == 300 for v in data["ours"].values())
    assert "safe_neither" in md.read_text()
    assert data["learned"] is None and data["incr"] == {}


def test_cli_table_with_learned_row_and_incr(tmp_path, capsys):
    from jaxdc import pretrained
    from jaxdc.dcp import learned as learned_lib

    params = learned_lib.init_params(learned_lib.make_network("linear"), 8, jax.random.PRNGKey(3))
    ckpt = pretrained.save(tmp_path / "lin", params, {"net": "linear", "problem": "dcp", "grid_size": 8,
                                                      "total_reward": 30, "risk": "high", "energy": [8, 16],
                                                      "max_steps": 1000, "steps": 1, "seed": 3})
    assert cli.main(["--table", "4.9", "--episodes", "40", "--out", str(tmp_path), "--checkpoint", ckpt]) == 0
    data = json.loads((tmp_path / "table_4.9.json").read_text())
    assert list(data["ours"]) == ["safe_reward", "safe_recharge", "safe_both", "safe_neither", "linear"]
    assert data["learned"]["net"] == "linear" and data["learned"]["seed"] == 3
    ours = data["ours"]
    for nav in ("safe_reward", "safe_neither"):
        for col in ("reward", "energy", "rpe"):
            th, got = data["incr"][nav][col]
            assert got == pytest.approx(100 * (ours["linear"][col]["mean"] - ours[nav][col]["mean"])
                                        / ours[nav][col]["mean"])
    # the thesis' own column, e.g. Table 4.9 linear energy over Safe-Neither: printed 88.52 %
    assert data["incr"]["safe_neither"]["energy"][0] == pytest.approx(88.47, abs=0.1)
    assert "incr.% over" in (tmp_path / "table_4.9.md").read_text()


def test_cli_table_best_row_is_the_best_shipped_candidate(tmp_path, capsys):
    from jaxdc.dcp.analysis.best_learner import candidates
    from jaxdc.dcp.analysis.tables import TABLES

    names = {c.name for c in candidates(TABLES["4.7"])}
    assert names == {"enn_ppo_energy16_32"}  # the only beyond-the-thesis ENN trained at energy 16/32
    assert cli.main(["--table", "4.7", "--episodes", "40", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    data = json.loads((tmp_path / "table_4.7.json").read_text())
    assert list(data["ours"])[-2:] == ["enn", "enn best"] and data["learned"]["row"] == "enn"
    best = data["best"]
    assert best["row"] == "enn best" and best["thesis_row"] == "enn" and best["checkpoint"] == "enn_ppo_energy16_32"
    assert best["differs"] == "the PPO-style option" and best["trained"]["energy"] == [16.0, 32.0]
    assert data["ours"]["enn best"]["episodes"] == 40
    for text in (out, (tmp_path / "table_4.7.md").read_text()):
        assert "| enn best: enn_ppo_energy16_32 | — |" in text
        assert "`enn_ppo_energy16_32` (beyond the thesis: the PPO-style option)" in text
    assert cli.main(["--table", "4.7", "--episodes", "40", "--out", str(tmp_path), "--no-best"]) == 0
    data = json.loads((tmp_path / "table_4.7.json").read_text())
    assert data["best"] is None and "enn best" not in data["ours"]


def test_best_candidates_are_read_from_the_metadata():
    from jaxdc.dcp.analysis.best_learner import candidates, differs, tables_of
    from jaxdc.dcp.analysis.tables import TABLES

    meta = {"tables": "4.3, 4.6, 4.8 (beyond the thesis: the PPO-style option, 1..30 units)"}
    assert tables_of(meta) == ("4.3", "4.6", "4.8") and differs(meta) == "the PPO-style option, 1..30 units"
    assert differs({"tables": "4.3, 4.6, 4.8"}) is None
    single = {c.name: c for c in candidates(TABLES["4.8"])}
    assert "enn" not in single and single["enn_single_item"].greedy and not single["enn_ppo_mix"].greedy
    assert candidates(TABLES["4.1"]) == [] and candidates(TABLES["4.4"]) == []


def test_cli_no_best_only_with_table(capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["--policy", "safe_reward", "--no-best", "--episodes", "10"])
    assert e.value.code == 2 and "--no-best applies only to --table" in capsys.readouterr().err


def test_cli_optimal_policy_matches_its_exact_value(capsys):
    # small map so that value iteration and the rollout compile fast
    assert cli.main(["--policy", "optimal", "--total-reward", "1", "--grid-size", "4", "--episodes", "3000",
                     "--risk", "high", "--energy", "4", "6", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    p = out["expected_optimum"]
    se = math.sqrt(p * (1 - p) / 3000)
    assert abs(out["reward"]["mean"] - p) < 4 * se + 1e-9


def test_cli_settles_the_arguments_once():
    args = cli.parse_args(["--policy", "safe_both", "--episodes", "7", "--seed", "3", "--no-idle-stop",
                                          "--cf-distance", "manhattan", "--grid-size", "5", "--max-steps", "40"])
    settings = cli.settle(args, None, None, ["--policy", "safe_both"])
    assert settings.policies == ("safe_both",) and settings.table is None and settings.learned is None
    assert settings.setting == Setting(5, 30, "high", (8.0, 16.0), 40)
    assert settings.options == EnvOptions(idle_terminates=False)
    assert (settings.playing.episodes, settings.playing.seed, settings.playing.planner.cf_distance) == (7, 3,
                                                                                                        "manhattan")
    assert settings.command == "python -m eval.dcp --policy safe_both"
    with pytest.raises(AttributeError):
        settings.out = "x"  # frozen


def test_eval_dcp_shim_is_the_cli():
    from eval import dcp as shim

    assert shim.main is cli.main and shim.build_parser is cli.build_parser


def test_cli_optimal_needs_single_item(capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["--policy", "optimal", "--episodes", "10"])
    assert e.value.code == 2
    assert "total_reward=1" in capsys.readouterr().err


def test_table_subcommand_is_the_table_flag_and_no_subcommand_is_evaluate():
    flag, sub = cli.parse_args(["--table", "4.8", "--no-learned"]), cli.parse_args(["table", "4.8", "--no-learned"])
    assert (flag.command, sub.command) == ("evaluate", "table")
    assert flag.table == sub.table == "4.8" and flag.no_learned and sub.no_learned and sub.policy is None
    assert cli.parse_args([]).policy == "safe_reward" and cli.parse_args([]).table is None
    with pytest.raises(SystemExit):
        cli.parse_args(["table", "4.8", "--policy", "enn"])


def test_command_line_is_recorded_as_given():
    from jaxdc.cli.runner import command_line, with_subcommand

    assert command_line(cli.PROG, ["--table", "4.3"]) == "python -m eval.dcp --table 4.3"
    assert command_line(cli.PROG, ["--risk-map", "my map.npy"]) == "python -m eval.dcp --risk-map 'my map.npy'"
    assert with_subcommand(["--table", "4.3"], cli.SUBCOMMANDS, "evaluate") == ["evaluate", "--table", "4.3"]
    assert with_subcommand(["table", "4.3"], cli.SUBCOMMANDS, "evaluate") == ["table", "4.3"]
