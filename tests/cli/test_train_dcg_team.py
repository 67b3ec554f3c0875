"""train.dcg --collectors K (the team game, beyond the thesis): a tiny IPPO run, recorded so --config reproduces
it, loaded back as a team network, and played by the team yardsticks."""

from __future__ import annotations

import json
import os

import jax
import pytest

from jaxdc.cli import train_dcg as cli
from jaxdc.cli.train_common import parse_with_config
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis import team
from jaxdc.dcg.team import DCGTeam
from jaxdc.training import dcg
from tests.support.cli_checks import refused, tiny_run

TINY = ["--net", "omn_conn", "--collectors", "2", "--grid-size", "4", "--total-reward", "4", "--strategies",
        "patrol", "--history", "2", "--max-steps", "20", "--steps", "128", "--envs", "8", "--t-max", "8",
        "--eval-every", "128", "--eval-episodes", "16", "--no-progress"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    return tiny_run(cli.main, TINY, tmp_path_factory)


def _settle(argv):
    return cli.settle(parse_with_config(cli.build_parser(), argv, "dcg", dcg.settings_from_metadata))


def test_the_run_records_the_team_and_config_reproduces_it(run_dir):
    with open(os.path.join(run_dir, "config.json")) as f:
        assert json.load(f)["collectors"] == 2
    settings, _ = _settle(TINY + ["--out", run_dir])
    again, _ = _settle(["--config", os.path.join(run_dir, "config.json"), "--eval-episodes", "16"])
    assert again == settings and again.collectors == 2
    plain, _ = _settle(["--net", "vnn"])
    assert plain.collectors == 1 and "collectors" not in dcg.run_metadata(plain, dcg.DCG(), [0])


def test_the_team_network_loads_with_its_team_game_and_plays_the_yardsticks(run_dir):
    learned = learned_lib.load(run_dir)
    env, _ = learned.game()
    assert isinstance(env, DCGTeam) and env.collectors == 2 and env.teammates
    assert learned.collectors == 2 and learned.net.state_channels == 3 and "a team of 2" in learned.describe()
    game, params = team.team_game(learned, 3)
    assert game.teammates and game.collectors == 3
    out = team.evaluate_team(game, params, team.copies(learned.policy(), 3), jax.random.PRNGKey(0), 20)
    assert 0 <= out["reward"]["mean"] <= 4


@pytest.mark.parametrize("value", ["0", "5", "two"])
def test_a_team_size_outside_1_to_4_is_refused(value, capsys, tmp_path):
    refused(cli.main, TINY[:2] + ["--collectors", value, "--out", str(tmp_path / "x")], capsys, "--collectors",
            value)
