"""A network whose body pools over the cells (``train.dcp --body-pool mean_max``) plays other grid sizes; the
generalisation grid plays it there with ``--grid-size``, and refuses that for a flattened body."""

import json
import os

import pytest


@pytest.fixture(scope="module")
def pooled_run(tmp_path_factory):
    from jaxdc.cli import train_dcp

    out = str(tmp_path_factory.mktemp("pool") / "run")
    rc = train_dcp.main(["--net", "enn", "--observation", "general", "--risk-maps", "bumps", "--map-seeds", "0", "8",
                         "--grid-size", "5", "--energy-range", "8", "20", "--total-reward", "5", "--steps", "1024",
                         "--envs", "8", "--t-max", "8", "--eval-every", "1024", "--eval-episodes", "16",
                         "--body-pool", "mean_max", "--body-features", "8", "4", "--body-hidden", "16", "--out", out,
                         "--no-progress"])
    assert rc == 0
    return out


def test_the_pool_is_recorded_retrained_by_config_and_plays_any_grid(pooled_run):
    from jaxdc.dcp import learned
    from jaxdc.training.dcp import settings_from_metadata

    meta = json.load(open(os.path.join(pooled_run, "config.json")))
    assert meta["body_pool"] == "mean_max" and meta["grid_size"] == 5
    settings, _ = settings_from_metadata(meta, "config.json")
    assert settings.body_pool == "mean_max" and settings.body() == {"body_features": (8, 4), "body_hidden": 16,
                                                                    "body_pool": "mean_max"}
    net = learned.load(pooled_run, grid_size=7)  # another grid size: the parameters fit every size
    assert net.net.body_pool == "mean_max" and learned.plays_any_grid(net.metadata)
    assert net.params["params"]["body"]["Dense_0"]["kernel"].shape == (2 * 4, 16)
    for bad in ("avg", ["mean_max"], 1):
        with pytest.raises(ValueError, match=r"^config.json: key 'body_pool': body_pool must be one of"):
            learned.check_setting({**meta, "body_pool": bad}, "config.json")


def test_cli_plays_the_grid_on_another_grid_size(pooled_run, tmp_path):
    from jaxdc.cli import eval_dcp

    out = str(tmp_path / "g7")
    rc = eval_dcp.main(["generalisation", "--checkpoint", pooled_run, "--grid-size", "7", "--maps-per-source", "1",
                        "--no-thesis", "--no-optimum", "--budgets", "8", "16", "--total-reward", "5",
                        "--episodes", "16", "--out", out])
    assert rc == 0
    payload = json.load(open(os.path.join(out, "generalisation.json")))
    assert payload["grid_size"] == 7 and len(payload["rows"]) == 5
    assert all(r["net"]["mean"] >= 0 and r["best_navigator"]["mean"] > 0 for r in payload["rows"])


def test_cli_refuses_another_grid_size_for_a_flattened_body(tmp_path, capsys):
    from jaxdc.cli import eval_dcp

    with pytest.raises(SystemExit) as e:
        eval_dcp.main(["generalisation", "--checkpoint", "enn_general_budget", "--grid-size", "10",
                       "--out", str(tmp_path / "x")])
    err = capsys.readouterr().err
    assert e.value.code == 2 and "--grid-size 10" in err and "trained on a 8x8 grid" in err
    assert not os.path.exists(tmp_path / "x")


def test_eval_dcp_plays_a_general_network_on_its_own_instance_path_at_any_grid_size(pooled_run, capsys):
    """``eval.dcp --checkpoint RUN --policy enn`` builds the environment with the observation the network reads
    (here the general one) and plays the map and budget through the per-episode path, on the same keys as
    ``evaluate_learned`` on :func:`jaxdc.dcp.instances.fixed_instance`; ``--grid-size`` another size for a pooled
    body. Before, a general network was refused there ("reads the 'general' observation")."""
    import jax
    import numpy as np

    from jaxdc.cli import eval_dcp
    from jaxdc.dcp import instances, learned
    from jaxdc.dcp.env import DCP
    from jaxdc.dcp.evaluate import evaluate_learned

    for size in (5, 7):
        capsys.readouterr()
        assert eval_dcp.main(["--checkpoint", pooled_run, "--policy", "enn", "--grid-size", str(size), "--risk",
                              "medium", "--energy", "6", "12", "--episodes", "24", "--seed", "3", "--json"]) == 0
        got = json.loads(capsys.readouterr().out)["reward"]["mean"]
        net = learned.load(pooled_run, grid_size=size)
        env = DCP(grid_size=size, total_reward=5, observation="general", idle_terminates=False)
        final = evaluate_learned(env, instances.fixed_instance(env, "medium", (6.0, 12.0)), net,
                                 jax.random.PRNGKey(3), 24)
        assert got == pytest.approx(float(np.mean(np.asarray(final.ep_reward))), abs=1e-6), size


def test_cli_refuses_a_grid_size_the_dcp_or_the_memory_cannot_hold(tmp_path, capsys, monkeypatch):
    """``--grid-size`` past the DCP's own bound (255) is refused by name before any map is drawn, and one whose
    safest-path tables do not fit names the grid size as what to lower; no output folder is left."""
    from jaxdc.cli import eval_dcp

    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**30))
    for size, match in (("5000", "--grid-size: grid_size must be <= 255"),
                        ("100", "the safest-path tables of 1 maps of 100x100 needs about")):
        with pytest.raises(SystemExit) as e:
            eval_dcp.main(["generalisation", "--checkpoint", "enn_general_pool", "--grid-size", size, "--no-thesis",
                           "--out", str(tmp_path / size)])
        err = capsys.readouterr().err
        assert e.value.code == 2 and match in err, err
        assert "the number of maps or the grid size" in err or size == "5000"
        assert not os.path.exists(tmp_path / size)


def test_cli_refuses_the_thesis_tables_for_a_network_of_another_grid_size_before_the_work(tmp_path, capsys):
    """The thesis tables are played on the thesis' 8x8 grid: a flattened network of another size needs
    ``--no-thesis``, refused by name before the grid is played (before, the grid ran and then failed on the
    parameters' shapes); a pooled network plays them."""
    from jaxdc.cli import eval_dcp, train_dcp

    run = str(tmp_path / "flat5")
    assert train_dcp.main(["--net", "enn", "--observation", "general", "--risk-maps", "bumps", "--map-seeds", "0",
                           "8", "--grid-size", "5", "--energy-range", "8", "20", "--total-reward", "5", "--steps",
                           "256", "--envs", "8", "--t-max", "8", "--eval-every", "256", "--eval-episodes", "8",
                           "--out", run, "--no-progress"]) == 0
    capsys.readouterr()
    with pytest.raises(SystemExit) as e:
        eval_dcp.main(["generalisation", "--checkpoint", run, "--maps-per-source", "1", "--budgets", "6", "12",
                       "--total-reward", "5", "--episodes", "8", "--out", str(tmp_path / "g")])
    err = capsys.readouterr().err
    assert e.value.code == 2 and "--no-thesis is needed" in err and "plays only 5x5" in err, err
    assert not os.path.exists(tmp_path / "g")
