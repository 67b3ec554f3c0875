"""jaxdc.training.presets and --config: named configurations and a run's own config.json as train.dcp / train.dcg
defaults (flags given override them)."""

import json

import pytest

from jaxdc.cli import train_dcg, train_dcp
from jaxdc.cli.train_common import parse_with_config
from jaxdc.training import dcg, dcp, presets
from jaxdc.training.dcg import make_env as dcg_env
from jaxdc.training.dcg import run_metadata as dcg_metadata
from jaxdc.training.dcp import run_metadata as dcp_metadata
from tests.support.cli_checks import refused


def _settle(module, argv, problem):
    parser = module.build_parser()
    from_metadata = (dcg if problem == "dcg" else dcp).settings_from_metadata
    return module.settle(parse_with_config(parser, argv, problem, from_metadata))


def test_every_preset_is_a_named_config_of_its_problem():
    assert set(presets.names("dcg")) == set(presets.DCG_STRONG) | set(presets.DCG_GENERAL) | set(presets.DCG_TEAM)
    assert "enn_ppo" in presets.names("dcp")
    assert set(presets.names("dcp")) == set(presets.ALL)


def test_a_named_config_settles_like_its_flags_and_given_flags_override():
    flags = presets.EVERY["enn_ppo"].flags()
    assert _settle(train_dcp, ["--config", "enn_ppo"], "dcp") == _settle(train_dcp, flags, "dcp")
    settings, control = _settle(train_dcp, ["--config=enn_ppo", "--lr", "1e-3", "--seed", "4"], "dcp")
    assert settings.config.lr == 1e-3 and control.seeds == (4,) and settings.config.clip_eps == 0.2
    dcg, _ = _settle(train_dcg, ["--config", "omn_conn_strong_areas"], "dcg")
    assert (dcg.net, dcg.reward_area, dcg.min_reward_area, dcg.config.total_steps) == ("omn_conn", 4, 1, 5_000_000)


@pytest.mark.parametrize("argv", [
    ["--net", "enn", "--risk", "low", "--energy", "6", "12", "--min-total-reward", "3", "--clip-eps", "0.2",
     "--normalize-advantages", "--reset-slots", "4", "--max-grad-norm", "0.5", "--seeds", "1,2"],
    ["--net", "eqn", "--grid-size", "5", "--total-reward", "7", "--target-every", "5000", "--lr", "3e-4"],
])
def test_a_dcp_run_config_retrains_the_same_run(argv, tmp_path):
    settings, control = _settle(train_dcp, argv, "dcp")
    (tmp_path / "config.json").write_text(json.dumps(dcp_metadata(settings, control.seeds)))
    again = _settle(train_dcp, ["--config", str(tmp_path / "config.json")], "dcp")
    assert again[0] == settings and again[1].seeds == control.seeds
    assert _settle(train_dcp, ["--config", str(tmp_path)], "dcp")[0] == settings  # the run folder itself


@pytest.mark.parametrize("argv", [
    ["--net", "emnn", "--alpha", "0.0001", "--energy", "10", "--history", "4", "--strategies", "patrol,with_fog"],
    ["--net", "omn_conn", "--omn-lr", "1e-3", "--reward-area", "3", "--min-reward-area", "2", "--seed", "9"],
    ["--net", "vnn", "--envs", "32", "--t-max", "32", "--gae-lambda", "0.95"],
    ["--net", "omn_conn", "--collectors", "2", "--init-from", "omn_conn_strong"],
])
def test_a_dcg_run_config_retrains_the_same_run(argv, tmp_path):
    settings, control = _settle(train_dcg, argv, "dcg")
    env, _ = dcg_env(settings)
    (tmp_path / "config.json").write_text(json.dumps(dcg_metadata(settings, env, control.seeds)))
    again, again_control = _settle(train_dcg, ["--config", str(tmp_path / "config.json")], "dcg")
    # the same run: its config.json (what shapes the trained parameters) is the one it was made from
    assert dcg_metadata(again, dcg_env(again)[0], again_control.seeds) == dcg_metadata(settings, env, control.seeds)
    assert again.config == settings.config and again.net == settings.net


def test_list_configs_prints_names(capsys):
    assert train_dcp.main(["--list-configs"]) == 0
    out = capsys.readouterr().out
    assert "enn_ppo_mix" in out and "vnn_strong" not in out
    assert train_dcg.main(["--list-configs"]) == 0
    assert "omn_conn_strong " in capsys.readouterr().out


def test_bad_configs_are_refused(tmp_path, capsys):
    refused(train_dcp.main, ["--config", "nope"], capsys, "--config 'nope'", "enn_ppo")
    refused(train_dcp.main, ["--config", "omn_conn_strong"], capsys, "DCG configuration", "train.dcg")
    refused(train_dcp.main, ["--config"], capsys, "--config needs")
    refused(train_dcp.main, ["--config", "enn", "--config", "eqn"], capsys, "more than once")
    bad = tmp_path / "config.json"
    for text, needle in (("{", "not a readable JSON"), ('{"net": "enn", "steps": NaN}', "NaN"),
                         ("[1]", "not a JSON object"), ('{"net": "vnn", "problem": "dcg", "algorithm": {}}', "DCG run"),
                         ('{"net": "enn", "algorithm": {}, "colour": 1}', "colour"),
                         ('{"net": "enn", "algorithm": {"unroll": 4}}', "unroll=4"),
                         ('{"format": 2, "net": "enn", "algorithm": {"warp": 1}}', "warp"),
                         ('{"net": "enn", "risk": true, "algorithm": {}}', "risk")):
        bad.write_text(text)
        refused(train_dcp.main, ["--config", str(bad)], capsys, needle)
    # a hostile value is refused, naming the setting
    bad.write_text(json.dumps({"net": "enn", "algorithm": {"lr": -1.0}}))
    refused(train_dcp.main, ["--config", str(bad)], capsys, "lr (learning rate)")
    bad.write_text(json.dumps({"net": "enn", "grid_size": 3, "max_steps": 10, "algorithm": {"gae_lambda": 2.0}}))
    refused(train_dcp.main, ["--config", str(bad)], capsys, "--gae-lambda")  # through the flag's own check
    bad.write_text(json.dumps({"net": "vnn", "problem": "dcg", "strategies": ["nope"], "algorithm": {}}))
    refused(train_dcg.main, ["--config", str(bad)], capsys, "nope")


def test_library_errors_name_fields_and_the_command_line_names_flags(capsys, tmp_path):
    from jaxdc.agents.a2c import A2CConfig
    from jaxdc.training.dcg import DCGRun, DCGSettings
    from jaxdc.training.fields import SettingError
    from jaxdc.training.loop import RunControl

    settings = DCGSettings(net="vnn", config=A2CConfig(total_steps=64, num_envs=2, t_max=4, aux_lr=1e-3))
    with pytest.raises(SettingError) as e:
        DCGRun(settings, RunControl(out="unused"))
    assert str(e.value).startswith("aux_lr sets OMN's learning rate and applies to net omn_conn only")
    assert e.value.render().startswith("--omn-lr sets OMN's learning rate and applies to --net omn_conn only")
    refused(train_dcg.main, ["--net", "vnn", "--omn-lr", "1e-3", "--steps", "64", "--envs", "2", "--t-max", "4",
                             "--out", str(tmp_path / "run")], capsys,
            "--omn-lr sets OMN's learning rate and applies to --net omn_conn only, not 'vnn'")
