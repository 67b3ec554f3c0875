"""The generalisation grid: a general network trained a few steps, played over maps and budgets by the CLI."""

import json
import os

import pytest

from jaxdc.dcp.analysis import generalisation as gen


@pytest.fixture(scope="module")
def tiny_general_run(tmp_path_factory):
    from jaxdc.cli import train_dcp

    out = str(tmp_path_factory.mktemp("gen") / "run")
    rc = train_dcp.main(["--net", "enn", "--observation", "general", "--risk-maps", "bumps", "--map-seeds", "0", "8",
                         "--energy-range", "8", "20", "--energy-tilt", "1.5", "--total-reward", "5", "--steps", "1024",
                         "--envs", "8", "--t-max", "8", "--eval-every", "1024", "--eval-episodes", "16", "--out", out,
                         "--heuristic-rows", "11", "--no-progress"])
    assert rc == 0
    return out


def test_run_records_its_instances_and_reloads(tiny_general_run):
    from jaxdc.dcp import learned

    meta = json.load(open(os.path.join(tiny_general_run, "config.json")))
    assert meta["observation"] == "general" and meta["risk_maps"] == "bumps" and meta["map_seeds"] == [0, 8]
    assert meta["energy_range"] == [8.0, 20.0] and meta["energy_tilt"] == 1.5
    from jaxdc.training.dcp import settings_from_metadata

    settings, _ = settings_from_metadata(meta, "config.json")
    assert settings.energy_tilt == 1.5 and settings.energy_range == (8.0, 20.0)
    assert meta["heuristic_rows"] == 11 and settings.heuristic_rows == 11  # Safe-Budget's row, recorded
    net = learned.load(tiny_general_run)
    assert net.observation == "general" and net.heuristic_rows == 11
    assert net.params["params"]["head"]["weights"]["kernel"].shape[-1] == 11 * 9
    assert gen.training_range(net.metadata) == (8.0, 20.0)


def test_grid_marks_sources_and_interpolation(tiny_general_run):
    from jaxdc.dcp import learned

    meta = learned.load(tiny_general_run).metadata
    grid = gen.settings(meta, maps_per_source=2, budgets=((4.0, 8.0), (16.0, 32.0)))
    assert [s.source for s in grid].count("train") == 4 and [s.source for s in grid].count("held-out") == 4
    assert [s.source for s in grid].count("thesis") == 6
    assert {s.inside for s in grid if s.energy == (4.0, 8.0)} == {True}
    assert {s.inside for s in grid if s.energy == (16.0, 32.0)} == {False}


def test_cli_writes_the_grid_with_navigators_optimum_and_heat_maps(tiny_general_run, tmp_path, capsys):
    from jaxdc.cli import eval_dcp

    out = str(tmp_path / "g")
    rc = eval_dcp.main(["generalisation", "--checkpoint", tiny_general_run, "--maps-per-source", "1", "--no-thesis",
                        "--budgets", "6", "12", "--total-reward", "5", "--episodes", "32", "--out", out, "--json"])
    assert rc == 0
    files = sorted(os.listdir(out))
    assert files == ["generalisation.json", "generalisation.md", "generalisation_one_item.png",
                     "generalisation_ratio.png"]
    payload = json.load(open(os.path.join(out, "generalisation.json")))
    assert [r["source"] for r in payload["rows"]] == ["train", "held-out", "thesis", "thesis", "thesis"]
    for r in payload["rows"]:
        assert r["best_navigator"]["mean"] == max(n["mean"] for n in r["navigators"].values())
        assert "safe_budget" not in r["navigators"]  # the thesis' four decide the ratio; Safe-Budget stands beside
        assert r["safe_budget"]["ratio"] == pytest.approx(r["safe_budget"]["mean"] / r["best_navigator"]["mean"])
        assert 0 < r["one_item"]["optimum"] <= 1 and r["one_item"]["net"] <= 1
    assert payload["rows"][0]["map"] == "train 0" and payload["rows"][1]["map"] == "held-out 1073741824"


def test_cli_refuses_odd_budgets(tiny_general_run, tmp_path, capsys):
    from jaxdc.cli import eval_dcp

    with pytest.raises(SystemExit) as e:
        eval_dcp.main(["generalisation", "--checkpoint", tiny_general_run, "--budgets", "8", "16", "12",
                       "--out", str(tmp_path / "x")])
    assert e.value.code == 2 and "--budgets takes pairs" in capsys.readouterr().err


def test_cli_bound_columns_pair_the_bound_with_the_navigators(tiny_general_run, tmp_path):
    from jaxdc.cli import eval_dcp

    out = str(tmp_path / "b")
    rc = eval_dcp.main(["generalisation", "--checkpoint", tiny_general_run, "--maps-per-source", "1", "--no-thesis",
                        "--no-optimum", "--budgets", "6", "12", "--total-reward", "5", "--episodes", "32", "--bound",
                        "--out", out])
    assert rc == 0
    payload = json.load(open(os.path.join(out, "generalisation.json")))
    for r in payload["rows"]:
        b = r["bound"]
        assert 0 < b["mean"] <= 5 and b["ceiling"] == pytest.approx(b["mean"] / r["best_navigator"]["mean"])
        assert b["net_share"] == pytest.approx(r["net"]["mean"] / b["mean"])
    assert all("ceiling_min" in s for s in payload["summary"])
    text = open(os.path.join(out, "generalisation.md")).read()
    assert "| net / bound | ceiling |" in text and "ceiling mean" in text


def test_cli_refuses_the_bound_with_too_many_items(tiny_general_run, tmp_path, capsys):
    from jaxdc.cli import eval_dcp

    with pytest.raises(SystemExit) as e:
        eval_dcp.main(["generalisation", "--checkpoint", tiny_general_run, "--total-reward", "21", "--bound",
                       "--out", str(tmp_path / "x")])
    assert e.value.code == 2 and "--bound needs --total-reward <= 20" in capsys.readouterr().err
    assert not os.path.exists(tmp_path / "x")
