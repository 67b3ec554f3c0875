"""Training over several grid sizes at once (beyond the thesis; docs/generalisation.md, "Other grid sizes"):
``a2c.make_train(..., extra_envs=...)`` and ``train.dcp --grid-sizes``.

The trainer splits its environments evenly over the sizes, the run records the sizes so ``--config`` reproduces it,
a resume ends where the uninterrupted run ends, a pooled network warm-starts a run of another grid size, and every
setting that cannot work is refused before any work, naming the flag.
"""

from __future__ import annotations

import functools
import json
import os

import jax
import numpy as np
import pytest

from jaxdc.agents import a2c
from jaxdc.cli import train_dcp as cli
from jaxdc.core import generators
from jaxdc.dcp import instances, learned
from jaxdc.dcp.env import DCP
from jaxdc.training import dcp
from tests.support.cli_checks import refused, restore_run, resumes_exactly, settle, tiny_run

# 2 x 512 steps of 8 environments (4 on each of the 4x4 and 5x5 grids) x 8 steps; PPO-style minibatches.
TINY = ["--net", "enn", "--grid-size", "5", "--grid-sizes", "4", "5", "--body-pool", "mean_max",
        "--observation", "general", "--risk-maps", "mix", "--map-seeds", "0", "8", "--energy-range", "6", "12",
        "--total-reward", "4", "--min-total-reward", "1", "--steps", "1024", "--envs", "8", "--t-max", "8",
        "--clip-eps", "0.2", "--epochs", "2", "--minibatches", "2", "--gae-lambda", "0.95",
        "--normalize-advantages", "--eval-every", "512", "--eval-episodes", "8", "--no-progress"]


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    return tiny_run(cli.main, TINY, tmp_path_factory)


def _group(n: int):
    env = DCP(grid_size=n, total_reward=4, observation="general")
    maps = generators.make_maps(generators.generator("mix"), generators.SeedSet(0, 4), n)
    params = instances.instance_params(env, maps, (6.0, 12.0), 0.5, 60)
    return env, params, instances.batched_heuristics(params)


def _trainer(pool: str | None = "mean_max", sizes=(4, 5), num_envs: int = 4, **options):
    config = a2c.A2CConfig(total_steps=10_000, num_envs=num_envs, t_max=4, **options)
    net = learned.make_network("enn", {} if pool is None else {"body_pool": pool})
    (env, params, heur), *rest = [_group(n) for n in sizes]
    return a2c.make_train(config, env, params, net, heur, extra_envs=tuple(a2c.EnvGroup(*g) for g in rest))


def test_the_batch_is_split_evenly_and_a_run_in_pieces_is_the_uninterrupted_run():
    trainer = _trainer(clip_eps=0.2, epochs=2, minibatches=2, gae_lambda=0.95, normalize_advantages=True)
    state = trainer.init(jax.random.PRNGKey(0))
    assert isinstance(state.obs, tuple) and [o.shape[:3] for o in state.obs] == [(2, 4, 4), (2, 5, 5)]
    whole, metrics = trainer.run(state, 4)
    half, _ = trainer.run(trainer.run(state, 2)[0], 2)
    for x, y in zip(jax.tree_util.tree_leaves(whole), jax.tree_util.tree_leaves(half)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    assert all(np.isfinite(np.asarray(leaf)).all() for leaf in jax.tree_util.tree_leaves(whole.params))
    assert int(whole.update) == 4 and np.asarray(metrics["loss"]).shape == (4,)
    moved = jax.tree_util.tree_map(lambda a, b: float(np.abs(np.asarray(a) - np.asarray(b)).max()),
                                   state.params, whole.params)
    assert max(jax.tree_util.tree_leaves(moved)) > 0  # it trains


def test_every_group_contributes_to_the_gradient():
    # the same trainer without its second size reaches other parameters after one update
    one = _trainer(sizes=(4,), num_envs=2)
    two = _trainer(sizes=(4, 5), num_envs=4)
    a, _ = one.update(one.init(jax.random.PRNGKey(1)))
    b, _ = two.update(two.init(jax.random.PRNGKey(1)))
    diffs = jax.tree_util.tree_leaves(jax.tree_util.tree_map(
        lambda x, y: float(np.abs(np.asarray(x) - np.asarray(y)).max()), a.params, b.params))
    assert max(diffs) > 0


def test_the_trainer_refuses_what_cannot_work():
    with pytest.raises(ValueError, match=r"extra_envs\[0\].*body_pool"):  # a flattened body on another size
        _trainer(pool=None)
    with pytest.raises(ValueError, match="num_envs .5. must be a multiple of the 2"):
        _trainer(num_envs=5)
    with pytest.raises(ValueError, match="minibatches"):
        _trainer(num_envs=4, minibatches=16)  # 4 x 4 / 2 = 8 rows per size: 8 minibatches would fit, 16 do not
    with pytest.raises(TypeError, match="extra_envs"):
        a2c.make_train(a2c.A2CConfig(num_envs=4, t_max=4), *_group(4)[:2], learned.make_network("enn", {}),
                       _group(4)[2], extra_envs=a2c.EnvGroup(*_group(5)))  # type: ignore[arg-type]


def test_the_run_records_its_sizes_and_config_reproduces_them(finished):
    with open(os.path.join(finished, "config.json")) as f:
        meta = json.load(f)
    assert meta["grid_sizes"] == [4, 5] and meta["grid_size"] == 5
    again, _ = settle(cli, "dcp", ["--config", os.path.join(finished, "config.json"), "--eval-episodes", "8"])
    assert again.grid_sizes == (4, 5) and again.body_pool == "mean_max"
    state = restore_run(cli, TINY, finished)
    assert [o.shape[1:3] for o in state.obs] == [(5, 5), (4, 4)]  # the evaluated size first


def test_a_resume_ends_where_the_uninterrupted_run_ends(finished, tmp_path):
    resumes_exactly(cli.main, TINY, finished, tmp_path, 16, functools.partial(restore_run, cli, TINY))


def test_a_pooled_network_warm_starts_a_run_of_another_grid_size(finished, tmp_path, tmp_path_factory, capsys):
    out = str(tmp_path / "warm4")
    argv = [*TINY[:2], "--grid-size", "4", *TINY[7:], "--init-from", finished, "--out", out]  # one size: 4x4
    run = cli.Run(cli.build_parser().parse_args(argv))
    start = run.trainer.init(jax.random.PRNGKey(3)).params
    jax.tree_util.tree_map(np.testing.assert_array_equal, start, learned.load(finished).params)
    # a flattened network still starts only its own grid size
    flat = [a for a in TINY[:2] + TINY[7:] if a != "mean_max" and a != "--body-pool"]
    source = tiny_run(cli.main, flat + ["--grid-size", "5", "--steps", "512"], tmp_path_factory)
    capsys.readouterr()
    refused(cli.main, flat + ["--grid-size", "4", "--init-from", source, "--out", str(tmp_path / "x")], capsys,
            "init_from", "grid_size is 5")


@pytest.mark.parametrize("argv, needles", [
    (["--grid-sizes", "4", "5"], ["--grid-sizes", "--body-pool"]),                       # a flattened body
    (["--grid-sizes", "5", "--body-pool", "mean_max"], ["--grid-sizes", "two distinct"]),
    (["--grid-sizes", "5", "5", "--body-pool", "mean_max"], ["--grid-sizes", "two distinct"]),
    (["--grid-sizes", "4", "6", "--body-pool", "mean_max"], ["--grid-sizes", "--grid-size (5)"]),
    (["--grid-sizes", "1", "5", "--body-pool", "mean_max"], ["--grid-sizes", "1"]),
    (["--grid-sizes", "4", "x", "--body-pool", "mean_max"], ["--grid-sizes", "'x'"]),
    (["--grid-sizes", "4", "300", "--body-pool", "mean_max"], ["--grid-sizes", "300"]),
    (["--grid-sizes", "4", "5", "--body-pool", "mean_max", "--envs", "5"], ["--envs", "--grid-sizes"]),
    (["--grid-sizes", "4", "5", "--body-pool", "mean_max", "--envs", "4", "--t-max", "2", "--minibatches", "8"],
     ["--minibatches", "--grid-sizes"]),
    (["--net", "eqn", "--grid-sizes", "4", "5", "--body-pool", "mean_max"], ["--grid-sizes", "n-step Q"]),
])
def test_a_setting_that_cannot_work_is_refused_before_any_work(argv, needles, capsys, tmp_path):
    out = tmp_path / "never"
    refused(cli.main, ["--grid-size", "5", "--steps", "1024", "--no-progress", *argv, "--out", str(out)], capsys,
            *needles)
    assert not out.exists()


def test_settings_refuse_a_bad_grid_sizes_value():
    config = a2c.A2CConfig(num_envs=4)
    for bad in ("45", 5, (4, 5.5), (4, True)):
        with pytest.raises((TypeError, ValueError), match="grid_sizes"):
            dcp.DCPSettings(net="enn", config=config, grid_size=5, grid_sizes=bad,  # type: ignore[arg-type]
                            body_pool="mean_max")
    ok = dcp.DCPSettings(net="enn", config=config, grid_size=5, grid_sizes=[4, 5], body_pool="mean_max")
    assert ok.grid_sizes == (4, 5)


def test_each_sizes_share_must_split_over_the_devices(tmp_path):
    """6 environments over 2 sizes are 3 per size: on 2 devices that share cannot split evenly (6 itself could)."""
    import subprocess
    import sys

    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2", JAX_PLATFORMS="cpu")
    argv = list(TINY)
    argv[argv.index("--envs") + 1] = "6"
    done = subprocess.run([sys.executable, "-m", "train.dcp", *argv, "--devices", "2", "--out", str(tmp_path / "r")],
                          env=env, capture_output=True, text=True, timeout=300,
                          cwd=os.path.dirname(os.path.dirname(os.path.dirname(__file__))))
    assert done.returncode == 2, done.stderr
    for needle in ("--envs (6)", "--grid-sizes", "3 environments per size", "--devices"):
        assert needle in done.stderr, (needle, done.stderr)
    assert "Traceback" not in done.stderr


def test_the_device_split_checks_every_groups_batch():
    """parallelize's check (jaxdc.agents.parallel.check_batched_divisible) looks at each group's batch, not at
    num_envs alone: 6 environments as 3 + 3 do not split over 2 devices."""
    from jaxdc.agents import parallel

    state = jax.eval_shape(_trainer(num_envs=6).init, jax.random.PRNGKey(0))
    parallel.check_batched_divisible(state, 3)  # 3 per group: one per device
    with pytest.raises(ValueError, match="batch of 3 .* devices .2."):
        parallel.check_batched_divisible(state, 2)
