"""train.dcg --algo mappo (a centralised critic on the world state; beyond the thesis, issue 29): recorded only
when set, reproduced by --config and --resume, shipped and loaded as the actor alone, refused without a team."""

from __future__ import annotations

import functools
import json
import os

import jax
import pytest

from jaxdc import pretrained
from jaxdc.agents.centralised import CRITIC
from jaxdc.cli import train_dcg as cli
from jaxdc.core.tree_check import digest
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis import team
from jaxdc.training import dcg
from tests.support.cli_checks import refused, restore_run, resumes_exactly, settle

# 2 updates of 8 envs x 8 steps, a checkpoint after each
TINY = ["--net", "omn_conn", "--collectors", "2", "--algo", "mappo", "--grid-size", "4", "--total-reward", "4",
        "--strategies", "patrol", "--history", "2", "--max-steps", "20", "--steps", "128", "--envs", "8",
        "--t-max", "8", "--eval-every", "64", "--eval-episodes", "16", "--no-progress"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("runs") / "mappo")
    assert cli.main(TINY + ["--out", out, "--ship", os.path.join(out, "net.msgpack")]) == 0
    return out




def test_the_run_records_mappo_and_config_reproduces_it(run_dir):
    with open(os.path.join(run_dir, "config.json")) as f:
        meta = json.load(f)
    assert meta["algo"] == "mappo" and meta["collectors"] == 2
    settings, _ = settle(cli, "dcg", TINY + ["--out", run_dir])
    again, _ = settle(cli, "dcg", ["--config", os.path.join(run_dir, "config.json"), "--eval-episodes", "16"])
    assert again == settings and again.algo == "mappo"
    # a flag given with --config overrides it
    assert settle(cli, "dcg", ["--config", run_dir, "--algo", "ippo"])[0].algo == "ippo"


def test_ippo_is_the_default_and_is_not_recorded():
    """Old runs' config.json files are unchanged: the default writes no "algo" key."""
    settings, control = settle(cli, "dcg", TINY[:4] + ["--out", "unused"])
    assert settings.algo == "ippo" and "algo" not in dcg.run_metadata(settings, dcg.make_env(settings)[0], [0])
    mappo, mappo_control = settle(cli, "dcg", TINY)
    assert dcg.run_metadata(mappo, dcg.make_env(mappo)[0], [0])["algo"] == "mappo"
    assert mappo_control.out.endswith("dcg-omn_conn-k2-mappo-e15-s0")
    assert settle(cli, "dcg", TINY[:4])[1].out.endswith("dcg-omn_conn-k2-e15-s0")


def test_the_shipped_team2_mappo_records_its_recipe_and_holds_the_actor_alone():
    """team2_mappo: the named config is team2's with algo mappo; the shipped file records it, the SHA-256 of the
    shipped omn_conn_strong it started from, and holds the actor only (no critic), playing as a team of two."""
    settings, _ = settle(cli, "dcg", ["--config", "team2_mappo"])
    team2, _ = settle(cli, "dcg", ["--config", "team2"])
    assert settings.algo == "mappo" and team2.algo == "ippo"
    assert settings.config == team2.config and settings.collectors == team2.collectors == 2
    assert settings.init_from == team2.init_from == "omn_conn_strong"
    path = pretrained.shipped("dcg", "team2_mappo")
    shipped = pretrained.read_metadata(path)
    assert shipped["algo"] == "mappo" and shipped["collectors"] == 2 and shipped["steps"] == 5_000_000
    env, env_params = dcg.make_env(settings)
    _, sha = dcg.start_params(settings, env, env_params, learned_lib.make_network("omn_conn", 10, env.state_channels))
    assert shipped["init_sha256"] == sha  # omn_conn_strong widened to the teammates plane, as for team2
    raw, _ = pretrained.load(path)
    assert CRITIC not in raw["params"]
    net = learned_lib.shipped("team2_mappo")
    assert net.collectors == 2 and net.metadata["algo"] == "mappo"


def test_the_checkpoint_holds_the_critic_and_a_resume_is_exact(run_dir, tmp_path):
    state = restore_run(cli, TINY, run_dir)
    assert CRITIC in state.params["params"]
    resumes_exactly(cli.main, TINY, run_dir, tmp_path, 2, functools.partial(restore_run, cli, TINY))


def test_the_shipped_network_is_the_actor_and_loads_as_a_policy(run_dir):
    shipped = os.path.join(run_dir, "net.msgpack")
    raw, _ = pretrained.load(shipped)
    assert CRITIC not in raw["params"]  # --ship writes the actor alone
    from_file = learned_lib.load(shipped)
    from_run = learned_lib.load(run_dir)
    for learned in (from_file, from_run):
        assert CRITIC not in learned.params["params"] and learned.collectors == 2
        assert learned.metadata["algo"] == "mappo" and "mappo" in learned.describe()
    assert digest(from_file.params) == digest(from_run.params)  # the final actor, from either source
    game, params = team.team_game(from_file, 2)
    out = team.evaluate_team(game, params, team.copies(from_file.policy(), 2), jax.random.PRNGKey(0), 16)
    assert 0 <= out["reward"]["mean"] <= 4


def test_a_parameter_file_holding_the_critic_loads_too(run_dir, tmp_path):
    """Loading works either way: a file saved with the whole trained tree plays its actor."""
    state = restore_run(cli, TINY, run_dir)
    meta = pretrained.read_metadata(os.path.join(run_dir, "net.msgpack"))
    path = pretrained.save(str(tmp_path / "whole.msgpack"), state.params, meta)
    learned = learned_lib.load(path)
    assert CRITIC not in learned.params["params"]
    assert digest(learned.params) == digest(learned_lib.load(run_dir).params)


def test_a_warm_start_from_a_mappo_run_reads_its_actor(run_dir, tmp_path):
    out = str(tmp_path / "warm")
    assert cli.main(TINY[:4] + TINY[6:] + ["--init-from", run_dir, "--out", out]) == 0  # an IPPO run
    with open(os.path.join(out, "config.json")) as f:
        meta = json.load(f)
    assert "algo" not in meta and meta["init_sha256"] == digest(learned_lib.load(run_dir).params)


def test_mappo_without_a_team_or_an_unknown_algo_is_refused(capsys, tmp_path):
    out = str(tmp_path / "x")
    one = ["--net", "omn_conn", "--algo", "mappo", "--out", out]
    err = refused(cli.main, one, capsys, "--algo", "'mappo'", "--collectors >= 2", "'ippo'")
    assert "got 1" in err
    refused(cli.main, TINY[:4] + ["--algo", "qmix", "--out", out], capsys, "--algo", "qmix", "ippo", "mappo")
    assert not os.path.exists(out)


def test_the_settings_refuse_them_before_any_work():
    config = dcg.a2c.A2CConfig(total_steps=64, num_envs=8, t_max=8)
    with pytest.raises(ValueError, match=r"algo 'mappo' .* needs collectors >= 2, got 1.*\('ippo', 'mappo'\)"):
        dcg.DCGSettings(net="vnn", config=config, algo="mappo")
    with pytest.raises(ValueError, match=r"algo must be one of \('ippo', 'mappo'\), got 'MAPPO'"):
        dcg.DCGSettings(net="vnn", config=config, collectors=2, algo="MAPPO")
    assert dcg.DCGSettings(net="vnn", config=config, collectors=2, algo="mappo").algo == "mappo"
