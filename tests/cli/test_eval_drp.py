"""The eval.drp command line (jaxdc.cli.eval_drp): plan output contract, errors, determinism, settings."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from jaxdc.cli import eval_drp as cli
from jaxdc.drp import world

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


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


def test_eval_drp_is_a_shim_over_the_cli_module():
    from eval import drp

    assert drp.main is cli.main and drp.build_parser is cli.build_parser


def test_arguments_settle_once_into_frozen_records(tmp_path):
    import dataclasses

    p = cli.build_parser()
    s = cli.settle(p.parse_args(["--out", "o", "figure", "3.4", "--quick", "--alphas", "20,5,2.5,5", "--workers", "1"]))
    assert isinstance(s, cli.FigureSettings)
    e = s.experiment
    assert (e.rewards, e.graphs, e.nodes, e.alphas, s.workers) == ("1-9", 10, 30, (0, 2.5, 5, 20), 1)
    assert e.tag == "r1-9_g10_n30_centre_s0"
    assert e.as_dict() == {"rewards": "1-9", "graphs": 10, "nodes": 30, "alphas": [0, 2.5, 5, 20], "base": "centre",
                        "seed": 0}
    with pytest.raises(dataclasses.FrozenInstanceError):
        e.graphs = 3
    g = cli.settle(p.parse_args(["gaps", "--alphas", "0,7"]))
    assert isinstance(g, cli.GapsSettings) and g.alphas == (0.0, 7.0) and g.out == cli.OUT_DIR
    pl = cli.settle(p.parse_args(["plan", "--graph", "g.json"]))
    assert pl == cli.PlanSettings(out=cli.OUT_DIR, graph="g.json", builder="gi", clustering="pgc", json=False,
                                  draw=None)


def test_figure_graphs_must_be_positive(capsys):
    with pytest.raises(SystemExit):
        cli.main(["figure", "3.1", "--graphs", "0"])
    assert "--graphs must be an integer >= 1, got 0" in capsys.readouterr().err
