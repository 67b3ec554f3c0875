"""train.ship: the commands that regenerate the shipped DCP networks."""

import pytest

from jaxdc.cli import train_ship
from jaxdc.training import ship


def test_train_command_uses_the_given_steps_unless_the_entry_fixes_them():
    cmd = ship.train_command("enn", 123, 4, "runs/x")
    assert cmd[:3] == ["python", "-m", "train.dcp"]
    assert cmd[cmd.index("--steps") + 1] == "123" and cmd[cmd.index("--seed") + 1] == "4"
    assert cmd[cmd.index("--out") + 1] == "runs/x/enn"
    single = ship.train_command("enn_single_item", 123, 0, "runs")
    assert single.count("--steps") == 1 and single[single.index("--steps") + 1] == "4000000"
    assert single[single.index("--total-reward") + 1] == "1"
    long = ship.train_command("enn_long", 123, 0, "runs")
    assert long.count("--steps") == 1 and long[long.index("--steps") + 1] == "16000000"


def test_every_shipped_file_has_an_entry_that_regenerates_it():
    import os

    from jaxdc.pretrained import ASSETS

    files = {f[:-len(".msgpack")] for f in os.listdir(os.path.join(ASSETS, "dcp")) if f.endswith(".msgpack")}
    assert files == set(ship.ALL)


def test_every_entry_names_a_dcp_network_and_its_tables():
    from jaxdc.nets import DCP_NETS

    for name, preset in ship.ALL.items():
        args = preset.flags()
        assert preset.description and args[0] == "--net" and args[1] in DCP_NETS, name


def test_bad_steps_is_a_usage_error_naming_the_flag(capsys):
    import pytest

    with pytest.raises(SystemExit) as e:
        train_ship.main(["--steps", "0", "--only", "enn"])
    assert e.value.code == 2 and "--steps must be an integer >= 1, got 0" in capsys.readouterr().err


def test_every_shipped_file_records_the_command_its_entry_gives():
    """The ``command`` in each shipped .json is what ``train.ship`` would run for it (entries and files agree)."""
    from jaxdc import pretrained

    for name in ship.ALL:
        recorded = pretrained.read_metadata(pretrained.shipped("dcp", name))["command"]
        assert recorded == " ".join(ship.train_command(name, 1_000_000, 0, "runs/ship")), name


def test_every_strong_dcg_file_has_an_entry_whose_command_trains_it():
    """Each shipped ``*_strong*`` DCG file is a ``train.ship`` entry, and the command recorded in its .json sets
    every train.dcg option as the entry's command does (the run folder aside)."""
    import os
    import shlex

    from jaxdc import pretrained
    from jaxdc.cli import train_dcg

    folder = os.path.join(pretrained.ASSETS, "dcg")
    files = {f[: -len(".msgpack")] for f in os.listdir(folder) if f.endswith(".msgpack") and "_strong" in f}
    assert files == set(ship.DCG_STRONG)
    parse = train_dcg.build_parser().parse_args
    for name in sorted(files):
        recorded = vars(parse(shlex.split(pretrained.read_metadata(os.path.join(folder, name + ".msgpack"))
                                          ["command"])[3:]))
        entry = vars(parse(ship.train_command(name, 1_000_000, 0, "runs/ship")[3:]))
        assert entry.pop("out") == f"runs/ship/{name}" and recorded.pop("out")
        entry.pop("resume"), recorded.pop("resume")  # a finished run resumed with --ship re-exports the same file
        assert recorded == entry, name
        assert entry["ship"] == f"jaxdc/assets/dcg/{name}.msgpack"


def test_the_children_run_the_installed_jaxdc_command():
    """train_all runs each recorded command through ``python -m jaxdc train ...`` (train/ is not in the wheel)."""
    import sys

    cmd = ship.train_command("enn", 2048, 0, "runs")
    assert ship.jaxdc_command(cmd) == [sys.executable, "-m", "jaxdc", "train", "dcp", *cmd[3:]]
    dcg = ship.train_command("vnn_strong", 2048, 0, "runs")
    assert ship.jaxdc_command(dcg)[3:5] == ["train", "dcg"]


def test_export_only_refuses_the_dcg_entries(capsys):
    import pytest

    with pytest.raises(SystemExit) as e:
        train_ship.main(["--export-only", "--only", "vnn_strong"])
    assert e.value.code == 2 and "written by train.dcg --ship" in capsys.readouterr().err


def test_the_tilted_general_network_records_its_recipe():
    """enn_general_tilt: enn_general's recipe with energy_tilt 1; the shipped file records it, and --config
    enn_general_tilt settles to the algorithm it was trained with."""
    import dataclasses

    from jaxdc import pretrained
    from jaxdc.cli import train_dcp
    from jaxdc.cli.train_common import parse_with_config
    from jaxdc.training import dcp

    args = parse_with_config(train_dcp.build_parser(), ["--config", "enn_general_tilt"], "dcp",
                             dcp.settings_from_metadata)
    settings, _ = train_dcp.settle(args)
    assert settings.energy_tilt == 1.0 and settings.config.gamma == 0.99 and settings.energy_range == (8.0, 48.0)
    shipped = pretrained.read_metadata(pretrained.shipped("dcp", "enn_general_tilt"))
    assert shipped["energy_tilt"] == 1.0 and shipped["energy_range"] == [8.0, 48.0] and shipped["seed"] == 0
    assert shipped["algorithm"] == dataclasses.asdict(settings.config)
    assert "energy_tilt" not in pretrained.read_metadata(pretrained.shipped("dcp", "enn_general"))


def test_the_budget_row_network_records_its_recipe():
    """enn_general_budget: enn_general_tilt's recipe with Safe-Budget's eleventh row; --config enn_general_budget
    settles to it, and the shipped file records it and loads with an eleven-row head."""
    from jaxdc import pretrained
    from jaxdc.cli import train_dcp
    from jaxdc.cli.train_common import parse_with_config
    from jaxdc.dcp import learned
    from jaxdc.training import dcp

    args = parse_with_config(train_dcp.build_parser(), ["--config", "enn_general_budget"], "dcp",
                             dcp.settings_from_metadata)
    settings, _ = train_dcp.settle(args)
    assert settings.heuristic_rows == 11 and settings.energy_tilt == 1.0 and settings.energy_range == (8.0, 48.0)
    shipped = pretrained.read_metadata(pretrained.shipped("dcp", "enn_general_budget"))
    assert shipped["heuristic_rows"] == 11 and shipped["seed"] == 0
    assert learned.load("enn_general_budget").heuristic_rows == 11
    assert "heuristic_rows" not in pretrained.read_metadata(pretrained.shipped("dcp", "enn_general_tilt"))


def test_the_pooled_network_records_its_recipe_and_plays_other_grid_sizes():
    """enn_general_pool: enn_general_budget's recipe with the body pooled over the cells; --config enn_general_pool
    settles to it, the shipped file records the pool, and it loads for a 6x6 and a 10x10 grid (a flattened body
    loads only for its own)."""
    from jaxdc import pretrained
    from jaxdc.cli import train_dcp
    from jaxdc.cli.train_common import parse_with_config
    from jaxdc.dcp import learned
    from jaxdc.training import dcp

    args = parse_with_config(train_dcp.build_parser(), ["--config", "enn_general_pool"], "dcp",
                             dcp.settings_from_metadata)
    settings, _ = train_dcp.settle(args)
    assert settings.body_pool == "mean_max" and settings.heuristic_rows == 11 and settings.energy_tilt == 1.0
    shipped = pretrained.read_metadata(pretrained.shipped("dcp", "enn_general_pool"))
    assert shipped["body_pool"] == "mean_max" and shipped["grid_size"] == 8 and shipped["seed"] == 0
    for size in (6, 10):
        assert learned.load("enn_general_pool", grid_size=size).net.body_pool == "mean_max"
    with pytest.raises(ValueError, match="trained on a 8x8 grid; it cannot play a 6x6 grid"):
        learned.load("enn_general_budget", grid_size=6)
    assert "body_pool" not in pretrained.read_metadata(pretrained.shipped("dcp", "enn_general_budget"))


def test_the_network_of_several_grid_sizes_records_its_sizes_and_its_start():
    """enn_general_sizes: enn_general_pool trained on over 6x6, 8x8 and 10x10 at once; --config settles to the sizes
    and the warm start, and the shipped file records both and loads for any grid size."""
    from jaxdc import pretrained
    from jaxdc.cli import train_dcp
    from jaxdc.cli.train_common import parse_with_config
    from jaxdc.dcp import learned
    from jaxdc.training import dcp

    args = parse_with_config(train_dcp.build_parser(), ["--config", "enn_general_sizes"], "dcp",
                             dcp.settings_from_metadata)
    settings, _ = train_dcp.settle(args)
    assert settings.grid_sizes == (6, 8, 10) and settings.grid_size == 8 and settings.config.num_envs == 48
    assert settings.init_from == "enn_general_pool" and settings.body_pool == "mean_max"
    shipped = pretrained.read_metadata(pretrained.shipped("dcp", "enn_general_sizes"))
    assert shipped["grid_sizes"] == [6, 8, 10] and shipped["init_from"] == "enn_general_pool"
    assert shipped["seed"] == 1 and shipped["grid_size"] == 8
    for size in (7, 12):
        assert learned.load("enn_general_sizes", grid_size=size).net.body_pool == "mean_max"
