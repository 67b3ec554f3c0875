"""jaxdc.cli.train_common: the one definition of the A2C flags, shared by train.dcp and train.dcg."""

from __future__ import annotations

import dataclasses

import pytest

from jaxdc.agents.a2c import A2CConfig
from jaxdc.cli import train_common as common
from jaxdc.cli import train_dcg, train_dcp

#: A value off the default for every A2CConfig field a flag sets (the command-line text, the parsed value).
OFF_DEFAULT = {
    "total_steps": ("8192", 8192), "num_envs": ("8", 8), "t_max": ("16", 16), "lr": ("0.002", 0.002),
    "gamma": ("0.9", 0.9), "entropy_coef": ("0.03", 0.03), "value_coef": ("0.5", 0.5),
    "max_grad_norm": ("0.7", 0.7), "reset_slots": ("3", 3), "gae_lambda": ("0.9", 0.9),
    "clip_eps": ("0.15", 0.15), "epochs": ("3", 3), "minibatches": ("2", 2), "normalize_advantages": (None, True),
}


def test_every_flag_is_covered_here_and_defaults_are_the_config_fields():
    assert set(OFF_DEFAULT) == set(common.A2C_FLAGS)
    defaults = {f.name: f.default for f in dataclasses.fields(A2CConfig)}
    for module in (train_dcp, train_dcg):
        args = module.build_parser().parse_args([])
        assert common.a2c_settings(args) == {f: defaults[f] for f in common.A2C_FLAGS}, module.__name__
    assert common.LEARNER_OPTIONS == {"gae_lambda": 1.0, "clip_eps": None, "epochs": 1, "minibatches": 1,
                                      "normalize_advantages": False}


@pytest.mark.parametrize("module", [train_dcp, train_dcg], ids=["dcp", "dcg"])
@pytest.mark.parametrize("field", sorted(OFF_DEFAULT))
def test_each_flag_reaches_the_config(module, field, tmp_path):
    text, value = OFF_DEFAULT[field]
    argv = [common.flag(field)] + ([] if text is None else [text])
    if field != "total_steps":
        argv += ["--steps", "8192"]
    run = module.Run(module.build_parser().parse_args(argv + ["--out", str(tmp_path / "run")]))
    assert getattr(run.config, field) == value
    others = {f: getattr(run.config, f) for f in common.A2C_FLAGS if f not in (field, "total_steps")}
    assert others == {f: getattr(A2CConfig(), f) for f in others}  # no flag sets another field


def test_eqn_refuses_the_a2c_learner_options(capsys, tmp_path):
    with pytest.raises(SystemExit) as e:
        train_dcp.main(["--net", "eqn", "--epochs", "2", "--clip-eps", "0.2", "--out", str(tmp_path / "q")])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "--clip-eps, --epochs" in err and "n-step Q-learning" in err
