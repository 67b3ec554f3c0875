"""The eval.drp command line: plan output contract, errors, determinism, figure summaries."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from eval import drp as cli
from jaxdc.drp import world

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(args, cwd):
    return subprocess.run([sys.executable, "-m", "eval.drp", "--out", str(cwd), *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def test_plan_json_contract_and_determinism(tmp_path):
    g = world.generate(5, n=9, size=40, alpha=15.0)
    world.save(g, tmp_path / "g.json")
    outs = [run(["plan", "--graph", str(tmp_path / "g.json"), "--builder", "gi", "--clustering", "pgc", "--json"],
                tmp_path) for _ in range(2)]
    assert outs[0].returncode == 0, outs[0].stderr
    assert outs[0].stdout == outs[1].stdout
    lines = outs[0].stdout.strip().splitlines()
    assert len(lines) == 1
    res = json.loads(lines[0])
    assert set(res) == {"expected_reward", "robots", "tours"}
    assert res["robots"] == len(res["tours"])
    visited = [v for t in res["tours"] for v in t]
    assert len(visited) == len(set(visited)) and all(1 <= v <= 9 for v in visited)
    D, beta, psi = world.arrays(g)
    plan = np.full((max(1, len(res["tours"])), 9), -1)
    for i, t in enumerate(res["tours"]):
        plan[i, : len(t)] = t
    assert float(world.expected_reward(D, beta, psi, plan)) == pytest.approx(res["expected_reward"], rel=1e-4)
    assert any(f.startswith("plan_g_gi_pgc") for f in os.listdir(tmp_path))


def test_plan_bad_file_names_the_field(tmp_path, capsys):
    (tmp_path / "bad.json").write_text(json.dumps({"base": [0, 0], "nodes": [[1, 1]], "rewards": [1],
                                                   "psi": 2.0, "alpha": 1}))
    assert cli.main(["--out", str(tmp_path), "plan", "--graph", str(tmp_path / "bad.json"), "--json"]) == 2
    err = capsys.readouterr()
    assert "psi must be in (0, 1], got 2.0" in err.err and err.out == ""


def test_summarise_normalises_by_alpha_zero():
    raw = {("nc", "gi"): np.array([[10.0, 5.0], [30.0, 5.0]]), ("pgc", "gi"): np.array([[10.0, 2.0], [30.0, 3.0]])}
    norm, rows = cli.summarise(raw, [0, 20])
    assert norm == 20.0
    r = {(x["clustering"], x["alpha"]): x for x in rows}
    assert r[("nc", 20)]["mean"] == 0.25 and r[("nc", 0)]["sd"] == 0.5
    assert r[("pgc", 20)]["pgc_over_nc"] == pytest.approx(0.5)
    md = cli.markdown_tables(rows, [20], ["gi"]).splitlines()
    assert md[0] == "| NC mean (SD) | α=20 |" and md[2] == "| GI | 0.250 (0.000) |"
    assert "| GI | 0.125 (0.025) |" in md and md[-1] == "| GI | 0.50 |"


def test_plot_writes_png(tmp_path):
    rows = [{"clustering": c, "builder": "gi", "alpha": a, "mean": 1.0 - a / 100, "sd": 0.1, "pgc_over_nc": 0.9}
            for c in ("nc", "pgc") for a in (0, 20)]
    cli._plot(rows, [0, 20], ["gi"], "3.4", str(tmp_path / "f.png"))
    assert (tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"


def test_plan_draw_writes_the_tours(tmp_path, capsys):
    from matplotlib.image import imread

    world.save(world.generate(5, n=9, size=40, alpha=15.0), tmp_path / "g.json")
    png = tmp_path / "plan.png"
    assert cli.main(["--out", str(tmp_path), "plan", "--graph", str(tmp_path / "g.json"), "--draw", str(png)]) == 0
    assert f"tours drawn to {png}" in capsys.readouterr().out
    img = imread(png)[..., :3]
    assert img.shape == (500, 500, 3)
    assert (img.max(axis=-1) - img.min(axis=-1) > 0.3).sum() > 100  # coloured tour lines, not only grey
    with pytest.raises(SystemExit):
        cli.main(["--out", str(tmp_path), "plan", "--graph", str(tmp_path / "g.json"), "--draw", "plan.jpg"])
    assert "must name a .png file" in capsys.readouterr().err


def test_builder_groups_cover_every_builder_once_and_balance():
    from jaxdc.drp.tours import BUILDERS

    for workers in (1, 2, 3, 6, 10):
        groups = cli.builder_groups(list(BUILDERS), workers)
        assert len(groups) == min(workers, len(BUILDERS))
        assert sorted(b for g in groups for b in g) == sorted(BUILDERS)
    two = cli.builder_groups(list(BUILDERS), 2)
    loads = sorted(sum(cli.NC_COST[b] for b in g) for g in two)
    assert loads[1] - loads[0] <= max(cli.NC_COST.values()) - min(cli.NC_COST.values())
    assert ["gi"] in [g[:1] for g in two]  # the heaviest builder starts a group


def test_figure_experiment_in_processes_equals_one_process():
    # Two worker processes (builder groups, PGC clusters sent by the parent) give exactly the rewards of the
    # in-process experiment: the rewards are computed from the tours on the host (float64), so neither the
    # compiled programs of another process nor the batches the tours were built in can move them.
    args = ("4-6", 2, 8, [0, 20, 40], "centre", 3)
    want, _ = cli.run_experiment(*args, ["ng", "gi"], ("nc", "pgc"), quiet=True)
    got, timing = cli.run_parallel(2, *args, False, True, builders=["ng", "gi"])
    assert sorted(got) == sorted(want)
    for key in want:
        np.testing.assert_array_equal(got[key], want[key])
    assert (want[("nc", "gi")][:, 1:] > 0).any()  # some robot is sent: the comparison is not vacuous
    assert {"pgc_clustering", "nc_gi", "nc_ng", "pgc_gi", "pgc_ng"} <= set(timing)
