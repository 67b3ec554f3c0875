"""train.dcg --collectors K (the team game, beyond the thesis): a tiny IPPO run, recorded so --config reproduces
it, loaded back as a team network, and played by the team yardsticks."""

from __future__ import annotations

import json
import os

import jax
import pytest

from jaxdc.cli import train_dcg as cli
from jaxdc.core.tree_check import digest
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis import team
from jaxdc.dcg.team import DCGTeam
from jaxdc.training import dcg
from tests.support.cli_checks import refused, settle, tiny_run

TINY = ["--net", "omn_conn", "--collectors", "2", "--grid-size", "4", "--total-reward", "4", "--strategies",
        "patrol", "--history", "2", "--max-steps", "20", "--steps", "128", "--envs", "8", "--t-max", "8",
        "--eval-every", "128", "--eval-episodes", "16", "--no-progress"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    return tiny_run(cli.main, TINY, tmp_path_factory)



def test_the_run_records_the_team_and_config_reproduces_it(run_dir):
    with open(os.path.join(run_dir, "config.json")) as f:
        assert json.load(f)["collectors"] == 2
    settings, _ = settle(cli, "dcg", TINY + ["--out", run_dir])
    again, _ = settle(cli, "dcg", ["--config", os.path.join(run_dir, "config.json"), "--eval-episodes", "16"])
    assert again == settings and again.collectors == 2
    plain, _ = settle(cli, "dcg", ["--net", "vnn"])
    assert plain.collectors == 1 and "collectors" not in dcg.run_metadata(plain, dcg.DCG(), [0])


def test_the_team_network_loads_with_its_team_game_and_plays_the_yardsticks(run_dir):
    learned = learned_lib.load(run_dir)
    env, _ = learned.game()
    assert isinstance(env, DCGTeam) and env.collectors == 2 and env.teammates
    assert learned.collectors == 2 and learned.net.state_channels == 3 and "a team of 2" in learned.describe()
    game, params = team.team_game(learned, 2)
    assert game.teammates and game.collectors == 2
    out = team.evaluate_team(game, params, team.copies(learned.policy(), 2), jax.random.PRNGKey(0), 20)
    assert 0 <= out["reward"]["mean"] <= 4
    with pytest.raises(ValueError, match="trained by a team of 2 collectors"):
        team.team_game(learned, 3)


@pytest.mark.parametrize("value", ["0", "5", "two"])
def test_a_team_size_outside_1_to_4_is_refused(value, capsys, tmp_path):
    refused(cli.main, TINY[:2] + ["--collectors", value, "--out", str(tmp_path / "x")], capsys, "--collectors",
            value)


# -- --init-from: a warm start (jaxdc.training.dcg.start_params) -----------------------------------------------
def test_a_team_started_from_a_one_collector_network_plays_exactly_its_copies():
    """The widened network ignores the teammates plane (zero weights): the same games, the same team rewards."""
    source = learned_lib.shipped("omn_conn_strong")
    settings, _ = settle(cli, "dcg", ["--net", "omn_conn", "--collectors", "2", "--init-from", "omn_conn_strong"])
    env, env_params = dcg.make_env(settings)
    net = learned_lib.make_network("omn_conn", 10, env.state_channels)
    params, sha = dcg.start_params(settings, env, env_params, net)
    assert sha == digest(params) and env.teammates
    warm = learned_lib.Learned("omn_conn", net, params, {**source.metadata, "collectors": 2}, "warm")
    key = jax.random.PRNGKey(3)
    played = team.evaluate_team(env, env_params, team.copies(warm.policy(), 2), key, 24)
    plain, plain_params = team.team_game(source, 2)
    assert not plain.teammates
    copied = team.evaluate_team(plain, plain_params, team.copies(source.policy(), 2), key, 24)
    assert played == copied


def test_a_warm_start_is_recorded_and_a_team_run_restarts_from_itself(run_dir, tmp_path):
    out = str(tmp_path / "again")
    assert cli.main(TINY + ["--init-from", run_dir, "--out", out]) == 0
    with open(os.path.join(out, "config.json")) as f:
        meta = json.load(f)
    source = learned_lib.load(run_dir)
    assert meta["init_from"] == run_dir and meta["init_sha256"] == digest(source.params)
    again, _ = settle(cli, "dcg", ["--config", out])
    assert again.init_from == run_dir and again.collectors == 2
    # a resume (its checkpoints/ folder exists) with the same warm start is the same run: nothing left to train
    assert cli.main(TINY + ["--init-from", run_dir, "--out", out, "--resume"]) == 0


def test_a_warm_start_from_another_setting_or_onto_its_own_files_is_refused(run_dir, capsys, tmp_path):
    out = str(tmp_path / "x")
    refused(cli.main, TINY + ["--collectors", "3", "--init-from", run_dir, "--out", out], capsys,
            "init_from", "a team of 2")
    refused(cli.main, TINY + ["--history", "3", "--init-from", run_dir, "--out", out], capsys,
            "init_from", "history is 2")
    refused(cli.main, TINY + ["--net", "vnn", "--init-from", run_dir, "--out", out], capsys,
            "init_from", "net is 'omn_conn'")
    refused(cli.main, TINY + ["--init-from", run_dir, "--out", run_dir], capsys, "--out", "--init-from")
    refused(cli.main, TINY + ["--init-from", "no_such_net", "--out", out], capsys, "no_such_net")
    assert not os.path.exists(out)
