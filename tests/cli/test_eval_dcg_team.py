"""eval.dcg --collectors K (beyond the thesis): a one-collector network as K copies in the team game, a team-trained
network in its own team only (jaxdc.dcg.analysis.team.evaluate_learned)."""

from __future__ import annotations

import json
import os

import jax
import pytest

from jaxdc.cli import eval_dcg
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis import team
from tests.support.cli_checks import refused


def test_copies_of_a_shipped_network_play_the_team_game(tmp_path, capsys):
    out = str(tmp_path / "res")
    assert eval_dcg.main(["--net", "omn_conn_strong", "--collectors", "2", "--episodes", "24", "--seed", "1",
                          "--json", "--out", out]) == 0
    r = json.loads(capsys.readouterr().out)
    assert (r["team"], r["collectors"], r["episodes"], r["net"]) == ("copies", 2, 24, "omn_conn")
    assert r["command"].endswith("--collectors 2 --episodes 24 --seed 1 --json --out " + out)
    with open(os.path.join(out, "team_omn_conn_strong_k2_e15_standard_s1.json")) as f:
        assert json.load(f)["reward"] == r["reward"]
    # the same games as the library's yardstick with the same key
    source = learned_lib.shipped("omn_conn_strong")
    env, params = team.team_game(source, 2)
    direct = team.evaluate_team(env, params, team.copies(source.policy(), 2), jax.random.PRNGKey(1), 24)
    assert direct["reward"] == r["reward"] and direct["any_caught"] == r["any_caught"]
    assert 0.0 <= r["reward"]["mean"] <= 10.0 and 0.0 <= r["caught_collectors"] <= r["any_caught"] <= 1.0


def test_a_team_network_plays_only_its_own_team_size():
    source = learned_lib.shipped("omn_conn_strong")
    net = learned_lib.make_network("omn_conn", 10, 3)
    fake = learned_lib.Learned("omn_conn", net, None, {**source.metadata, "collectors": 2}, "a-team.msgpack")
    with pytest.raises(ValueError, match=r"collectors=3: omn_conn \(a-team.msgpack\) was trained by a team of 2"):
        team.team_game(fake, 3)
    with pytest.raises(ValueError, match="collectors must be"):
        team.evaluate_learned(source, collectors=5)


@pytest.mark.parametrize("argv, needles", [
    (["--collectors", "5"], ("--collectors", "5")),
    (["--collectors", "0"], ("--collectors", "0")),
    (["--collectors", "2", "--reward-area", "2"], ("--reward-area", "team")),
    (["--collectors", "2", "--mask", "reach_base"], ("--mask reach_base", "one collector", "team")),
])
def test_bad_team_flags_are_refused(argv, needles, tmp_path, capsys):
    refused(eval_dcg.main, ["--net", "omn_conn_strong", "--episodes", "4", "--out", str(tmp_path), *argv], capsys,
            *needles)


def test_a_team_network_renders_every_collector(tmp_path, capsys):
    out = str(tmp_path / "render")
    assert eval_dcg.main(["render", "--net", "team2", "--strategy", "restricted", "--seed", "3", "--max-steps", "4",
                          "--out", out]) == 0
    assert sorted(os.listdir(out)) == ["dcg_team2_k2_restricted_s3.gif", "dcg_team2_k2_restricted_s3.png"]
    assert capsys.readouterr().out.startswith("omn_conn vs restricted, seed 3:")
