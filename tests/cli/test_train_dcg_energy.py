"""train.dcg over a range of maximum energies (beyond the thesis, docs/generalisation.md): a tiny run with
--energy-range (tilted), the general observation and an action mask, recorded so --config reproduces it, then
played at fixed energies by the loader and by ``eval.dcg energies``."""

from __future__ import annotations

import dataclasses
import json
import os

import numpy as np
import pytest

from jaxdc import pretrained
from jaxdc.cli import eval_dcg
from jaxdc.cli import train_dcg as cli
from jaxdc.cli.eval_dcg_energies import network_label
from jaxdc.core.tree_check import digest
from jaxdc.dcg import learned as learned_lib
from jaxdc.training import dcg, presets, ship
from tests.support.cli_checks import refused, settle, tiny_run

# 3x3 grid, 3 items, the restricted chaser, VNN (no history planes); one update of 16 envs x 8 steps.
TINY = ["--net", "vnn", "--grid-size", "3", "--total-reward", "3", "--strategies", "restricted", "--max-steps", "20",
        "--energy-range", "3", "8", "--energy-tilt", "1.5", "--observation", "general", "--steps", "128",
        "--envs", "16", "--t-max", "8", "--mask", "reach_base",
        "--eval-every", "128", "--eval-episodes", "16", "--no-progress"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    return tiny_run(cli.main, TINY, tmp_path_factory)



def test_the_run_records_the_range_and_config_reproduces_it(run_dir):
    with open(os.path.join(run_dir, "config.json")) as f:
        meta = json.load(f)
    assert meta["energy_range"] == [3.0, 8.0] and meta["energy_tilt"] == 1.5 and meta["observation"] == "general"
    assert meta["mask"] == "reach_base"
    settings, _ = settle(cli, "dcg", TINY + ["--out", run_dir])
    again, _ = settle(cli, "dcg", ["--config", os.path.join(run_dir, "config.json"), "--eval-episodes", "16"])
    assert again == settings and again.energy_range == (3.0, 8.0) and again.observation == "general"
    assert again.energy_tilt == 1.5 and again.mask == "reach_base"
    # the faithful default writes none of the keys
    plain, _ = settle(cli, "dcg", ["--net", "vnn"])
    assert not {"energy_range", "energy_tilt", "mask"} & set(dcg.run_metadata(plain, dcg.DCG(), [0]))
    assert plain.observation == "thesis" and plain.energy_tilt == 0.0 and plain.mask == "none"


def test_the_network_plays_its_range_or_any_fixed_energy(run_dir):
    learned = learned_lib.load(run_dir)
    assert learned.net.state_channels == 3 and "energies 3-8 (general observation)" in learned.describe()
    env, params = learned.game()
    assert env.observation == "general" and params.energy_range.tolist() == [3.0, 8.0]
    env, params = learned.game(energy=5)
    assert params.energy_range is None and float(params.max_energy) == 5.0
    assert env.observation_shape() == (3, 3, 3)


def test_eval_energies_writes_the_table_per_energy(run_dir, tmp_path, capsys):
    out = str(tmp_path / "res")
    argv = ["energies", "--checkpoint", run_dir, "--energies", "3", "8", "9", "--episodes", "32",
            "--bound-episodes", "4", "--no-specialists", "--mask", "none", "--json", "--out", out]
    assert eval_dcg.main(argv) == 0
    table = json.loads(capsys.readouterr().out)
    assert [r["energy"] for r in table["rows"]] == [3.0, 8.0, 9.0]
    assert [r["in_range"] for r in table["rows"]] == [True, True, False]
    for r in table["rows"]:
        assert r["bound"]["mean"] > 0 and r["specialist"] is None
        np.testing.assert_allclose(r["ratio"], r["reward"]["mean"] / r["bound"]["mean"])
    # named after the network as given (the run folder "tiny"), not its class, so another VNN does not overwrite it;
    # the source recorded is the argument, not this machine's absolute path
    assert sorted(os.listdir(out)) == ["energies_tiny_s0.json", "energies_tiny_s0.md"]
    assert table["source"] == run_dir
    assert "| 9 | no |" in open(os.path.join(out, "energies_tiny_s0.md")).read()


@pytest.mark.parametrize("given, label", [
    ("omn_conn_general_long", "omn_conn_general_long"), ("nets/a.msgpack", "a"), ("runs/x/", "x"), ("runs/x", "x")])
def test_energies_files_are_named_after_the_network_as_given(given, label):
    assert network_label(given) == label


def test_the_named_recipe_settles():
    settings, _ = settle(cli, "dcg", ["--config", "omn_conn_general"])
    assert settings.energy_range == (8.0, 25.0) and settings.observation == "general" and settings.net == "omn_conn"
    assert presets.EVERY["omn_conn_general"].flags()[:2] == ["--net", "omn_conn"]


def test_the_long_general_collector_records_its_recipe_and_the_file_it_started_from():
    """omn_conn_general_long: the named config's settings, started from the shipped omn_conn_general -- the
    recorded SHA-256 is that of the shipped file's parameters (a retrained or replaced source would differ)."""
    settings, _ = settle(cli, "dcg", ["--config", "omn_conn_general_long"])
    assert settings.init_from == "omn_conn_general" and settings.config.total_steps == 10_000_000
    assert settings.config.lr == 3e-4 and settings.energy_range == (8.0, 25.0) and settings.observation == "general"
    shipped = pretrained.read_metadata(pretrained.shipped("dcg", "omn_conn_general_long"))
    assert shipped["init_from"] == "omn_conn_general" and shipped["steps"] == 10_000_000
    assert shipped["init_sha256"] == digest(learned_lib.shipped("omn_conn_general").params)
    assert shipped["algorithm"] == dataclasses.asdict(settings.config)


def test_the_tilted_general_collector_records_its_recipe_and_the_file_it_started_from():
    """omn_conn_general_tilt: omn_conn_general_long trained on with energy_tilt 2, from the shipped file."""
    settings, _ = settle(cli, "dcg", ["--config", "omn_conn_general_tilt"])
    assert settings.init_from == "omn_conn_general_long" and settings.energy_tilt == 2.0
    assert settings.config.total_steps == 5_000_000 and settings.config.lr == 2e-4
    shipped = pretrained.read_metadata(pretrained.shipped("dcg", "omn_conn_general_tilt"))
    assert shipped["energy_tilt"] == 2.0 and shipped["energy_range"] == [8.0, 25.0] and shipped["seed"] == 4
    assert shipped["init_sha256"] == digest(learned_lib.shipped("omn_conn_general_long").params)
    assert shipped["algorithm"] == dataclasses.asdict(settings.config)


def test_the_masked_general_collector_records_its_recipe_and_plays_under_its_mask():
    """omn_conn_general_masked: omn_conn_general_tilt trained on under reach_base_or_item, from the shipped file;
    loaded, it plays under that mask."""
    settings, _ = settle(cli, "dcg", ["--config", "omn_conn_general_masked"])
    assert settings.init_from == "omn_conn_general_tilt" and settings.mask == "reach_base_or_item"
    assert settings.energy_tilt == 2.0 and settings.config.total_steps == 4_000_000
    learned = learned_lib.shipped("omn_conn_general_masked")
    assert learned.mask == "reach_base_or_item" and "under the mask reach_base_or_item" in learned.describe()
    assert learned.metadata["init_sha256"] == digest(learned_lib.shipped("omn_conn_general_tilt").params)
    assert learned.metadata["algorithm"] == dataclasses.asdict(settings.config)


@pytest.mark.parametrize("name, start, tilt, steps, seed", [
    ("omn_conn_general_tilt3", "omn_conn_general_masked", 3.0, 8_000_000, 6),
    ("omn_conn_general_tilt4", "omn_conn_general_tilt3", 4.0, 6_000_000, 7),
])
def test_the_tilted_collectors_record_their_recipe_seed_and_start(name, start, tilt, steps, seed):
    """The harder tilts: a shipped collector trained on under its mask with a larger energy_tilt, from the shipped
    file it names; the preset fixes the seed the shipped file was trained with (train.ship's command uses it)."""
    settings, _ = settle(cli, "dcg", ["--config", name])
    assert settings.init_from == start and settings.mask == "reach_base_or_item"
    assert settings.energy_tilt == tilt and settings.config.total_steps == steps and settings.config.lr == 1e-4
    learned = learned_lib.shipped(name)
    assert learned.mask == "reach_base_or_item" and learned.metadata["seed"] == seed
    assert learned.metadata["init_sha256"] == digest(learned_lib.shipped(start).params)
    assert learned.metadata["algorithm"] == dataclasses.asdict(settings.config)
    assert f"--seed {seed}" in " ".join(ship.train_command(name, 0, 0, "runs"))


@pytest.mark.parametrize("argv, match", [
    (["--energy-range", "8", "3"], "energy_range: low (8) must not exceed high (3)"),
    (["--energy-range", "8.5", "12"], "energy_range low must be a whole number, got 8.5"),
    (["--energy-range", "0", "12"], "--energy-range"),
    (["--energy-range", "inf", "12"], "--energy-range"),
    (["--energy-range", "8"], "--energy-range"),
    (["--observation", "budget"], "--observation"),
    (["--energy-range", "8", "12", "--energy-tilt", "9"], "--energy-tilt"),
    (["--energy-range", "8", "12", "--energy-tilt", "nan"], "--energy-tilt"),
    (["--energy-tilt", "1"], "--energy-tilt=1 tilts the draw of --energy-range and needs it"),
    (["--mask", "reach_home"], "--mask"),
    (["--mask", "reach_base", "--collectors", "2"], "--mask 'reach_base' plays one collector's state"),
])
def test_bad_ranges_and_observations_are_usage_errors(argv, match, capsys, tmp_path):
    refused(cli.main, ["--net", "vnn", "--out", str(tmp_path / "x")] + argv, capsys, match)


def test_a_collector_under_the_reach_base_mask_never_runs_dry(run_dir):
    """``mask="reach_base"`` (beyond the thesis, jaxdc.core.masks): the DCG shares the DCP's energy rule, so a
    collector that may only make moves that leave its energy the way home is never disabled by its energy; the
    same games without the mask are (a barely trained network on a small budget). A network trained under a
    mask plays under it unless told otherwise."""
    from jaxdc.dcg.analysis.collector_eval import evaluate

    learned = learned_lib.load(run_dir)
    assert learned.mask == "reach_base"
    free = evaluate(learned, episodes=256, seed=1, energy=3, mask="none")
    masked = evaluate(learned, episodes=256, seed=1, energy=3)  # as trained
    assert free["outcomes"]["energy"] > 0 and "mask" not in free
    assert masked["outcomes"]["energy"] == 0 and masked["mask"] == "reach_base"
    with pytest.raises(ValueError, match="mask must be one of"):
        evaluate(learned, episodes=8, seed=1, mask="reach_home")


def test_eval_energies_under_a_mask_records_it_and_names_its_files(run_dir, tmp_path, capsys):
    out = str(tmp_path / "res")
    argv = ["energies", "--checkpoint", run_dir, "--energies", "3", "--episodes", "32", "--bound-episodes", "4",
            "--no-specialists", "--mask", "reach_base", "--json", "--out", out]
    assert eval_dcg.main(argv) == 0
    table = json.loads(capsys.readouterr().out)
    assert table["mask"] == "reach_base"
    assert sorted(os.listdir(out)) == ["energies_tiny_mask-reach_base_s0.json", "energies_tiny_mask-reach_base_s0.md"]
    assert "under the action mask `reach_base`" in open(os.path.join(out, "energies_tiny_mask-reach_base_s0.md")).read()
    refused(eval_dcg.main, argv[:-3] + ["--mask", "reach_home"], capsys, "--mask", "reach_home")
