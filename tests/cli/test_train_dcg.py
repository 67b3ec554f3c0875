"""The train.dcg command line: a tiny VNN run that beats the uniform policy, exact --resume, an EMNN run with
its opponent accuracy and --ship, clear errors."""

from __future__ import annotations

import csv
import functools
import os

import jax
import numpy as np
import pytest

from jaxdc import checkpoint, pretrained
from jaxdc.cli import train_dcg as cli
from jaxdc.core.rollout import run_episodes
from jaxdc.nets import make_dcg_net
from tests.support.cli_checks import refused, restore_run, resumes_exactly, tiny_run

# 3x3 grid, 3 items, the restricted chaser, k = 2; 150 updates of 16 envs x 8 steps, checkpoints at 75 and 150.
TINY = ["--net", "vnn", "--grid-size", "3", "--total-reward", "3", "--strategies", "restricted", "--history", "2",
        "--energy", "8", "--max-steps", "20", "--steps", "19200", "--envs", "16", "--t-max", "8", "--lr", "3e-3",
        "--eval-every", "9600", "--eval-episodes", "500", "--no-progress"]


def _fails(capsys, argv, match):
    refused(cli.main, argv, capsys, match)


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    return tiny_run(cli.main, TINY, tmp_path_factory)


@pytest.fixture(scope="module")
def emnn_run(tmp_path_factory):
    """One update of EMNN (opponent-action head), shipped."""
    out = str(tmp_path_factory.mktemp("runs") / "emnn")
    argv = TINY + ["--net", "emnn", "--steps", "128", "--eval-every", "128", "--eval-episodes", "8"]
    assert cli.main(argv + ["--out", out, "--ship", os.path.join(out, "emnn.msgpack")]) == 0
    return out



def _rows(out):
    with open(os.path.join(out, "metrics.csv")) as f:
        return list(csv.DictReader(f))


def test_tiny_run_beats_the_uniform_policy(finished_run):
    rows = _rows(finished_run)
    assert [int(r["env_steps"]) for r in rows] == [9600, 19200] and float(rows[-1]["lr"]) == 0.0
    assert checkpoint.steps(os.path.join(finished_run, "checkpoints")) == [75, 150]
    assert rows[-1]["eval_opponent_accuracy"] == "" and rows[-1]["aux_loss"] == ""  # VNN has no such head
    run = cli.Run(cli.build_parser().parse_args(TINY + ["--out", finished_run]))
    uniform = lambda k, obs, state: jax.random.randint(k, (), 0, 9)  # noqa: E731
    play = jax.jit(lambda key: run_episodes(run.env, run.env_params, uniform, key, 500))  # jitted: not op by op
    r_uniform = float(play(jax.random.PRNGKey(7)).ep_reward.mean())
    # measured: uniform 0.35, the trained VNN about 1.0 (of 3)
    assert float(rows[-1]["eval_reward"]) > r_uniform + 0.3, (rows[-1]["eval_reward"], r_uniform)


def test_resume_ends_with_the_same_parameters(finished_run, tmp_path):
    out = resumes_exactly(cli.main, TINY, finished_run, tmp_path, 150, functools.partial(restore_run, cli, TINY))
    assert [r["eval_reward"] for r in _rows(out)] == [r["eval_reward"] for r in _rows(finished_run)]


def test_emnn_reports_opponent_accuracy_and_ships_loadable_parameters(emnn_run):
    (row,) = _rows(emnn_run)
    assert 0.0 <= float(row["eval_opponent_accuracy"]) <= 1.0 and 0.0 <= float(row["aux_accuracy"]) <= 1.0
    assert float(row["aux_loss"]) > 0
    params, meta = pretrained.load(os.path.join(emnn_run, "emnn.msgpack"), net="emnn", problem="dcg")
    assert meta["history"] == 2 and meta["alpha"] == 0.001 and meta["steps"] == 128 and meta["energy"] == 8.0
    assert meta["algorithm"]["aux_coef"] == 0.001 and meta["obs_history"] is True
    assert meta["strategies"] == ["restricted"] and meta["command"].startswith("python -m train.dcg ") \
        and "--net emnn" in meta["command"]
    run = cli.Run(cli.build_parser().parse_args(TINY + ["--net", "emnn", "--steps", "128", "--out", emnn_run]))
    state, _ = checkpoint.restore(run.ckpt_dir, run.trainer.init(jax.random.PRNGKey(0)), run.metadata)
    for x, y in zip(jax.tree_util.tree_leaves(state.params), jax.tree_util.tree_leaves(params)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    net = make_dcg_net(meta["net"], meta["history"])
    assert net.apply(params, np.zeros((1, 3, 3, 4), np.float32))[2].shape == (1, 9)


def test_reward_area_training_is_recorded_and_replayed(tmp_path):
    """--reward-area trains on the one-item game of section 5.5.5; its metadata replays that game."""
    from jaxdc.dcg import learned as learned_lib

    out = str(tmp_path / "area")
    run = cli.Run(cli.build_parser().parse_args(TINY + ["--total-reward", "1", "--reward-area", "2", "--out", out]))
    assert run.env.reward_area == 2 and run.env.total_reward == 1
    assert run.metadata["reward_area"] == 2 and run.metadata["total_reward"] == 1
    learned = learned_lib.Learned("vnn", run.net, None, run.metadata, "test")
    env, _ = learned.game()
    assert env.reward_area == 2 and env.total_reward == 1
    env, _ = learned.game(reward_area=1)  # evaluated on another reward area
    assert env.reward_area == 1 and env.total_reward == 1
    assert "bottom-right 2x2 square" in learned.describe()
    # a run without the option records reward_area None (metadata format 2; older files are upgraded on load)
    assert cli.Run(cli.build_parser().parse_args(TINY + ["--out", out])).metadata["reward_area"] is None
    # --min-reward-area: a mix of sizes in training; a figure's size is played alone
    run = cli.Run(cli.build_parser().parse_args(TINY + ["--reward-area", "3", "--min-reward-area", "1",
                                                        "--out", str(tmp_path / "mix")]))
    assert (run.env.reward_area, run.env.min_reward_area, run.metadata["min_reward_area"]) == (3, 1, 1)
    learned = learned_lib.Learned("vnn", run.net, None, run.metadata, "test")
    assert learned.game()[0].min_reward_area == 1 and "(sizes 1-3)" in learned.describe()
    env, _ = learned.game(reward_area=2)
    assert (env.reward_area, env.min_reward_area) == (2, None)


def test_resume_refuses_another_net(finished_run, capsys):
    _fails(capsys, TINY + ["--out", finished_run, "--resume", "--net", "imnn"], "net: checkpoint has 'vnn'")
    _fails(capsys, TINY + ["--out", finished_run], "already holds checkpoints")


def test_seeds_run_vmapped_and_seed_0_equals_the_single_run(finished_run, tmp_path, capsys):
    """--seeds 0,3 (train.common's flag, as in train.dcp): one vmapped run whose seed 0 equals the single run of
    seed 0, one CSV per seed, and the PPO-style learner options accepted on the same run."""
    out = str(tmp_path / "seeds")
    assert cli.main(TINY + ["--out", out, "--seeds", "0,3"]) == 0
    run = cli.Run(cli.build_parser().parse_args(TINY + ["--out", out, "--seeds", "0,3"]))
    multi, _ = checkpoint.restore(run.ckpt_dir, run.trainer.init(run.init_key()), run.metadata)
    single = restore_run(cli, TINY, finished_run)
    for x, y in zip(jax.tree_util.tree_leaves(single.params), jax.tree_util.tree_leaves(multi.params)):
        np.testing.assert_allclose(np.asarray(x), np.asarray(y)[0], rtol=1e-4, atol=1e-5)
    assert not np.allclose(*np.asarray(jax.tree_util.tree_leaves(multi.params)[0]))
    for seed in (0, 3):
        with open(os.path.join(out, f"metrics-s{seed}.csv")) as f:
            assert [int(r["env_steps"]) for r in csv.DictReader(f)] == [9600, 19200]
    assert run.metadata["seeds"] == [0, 3] and "seed" not in run.metadata
    # each seed is loaded (learned.load's run_seed) and played (eval.dcg --run-seed) on its own
    from jaxdc.cli import eval_dcg
    from jaxdc.dcg import learned as learned_lib

    three = learned_lib.load(out, run_seed=3)
    for x, y in zip(jax.tree_util.tree_leaves(three.params), jax.tree_util.tree_leaves(multi.params)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y)[1])
    assert three.metadata["seed"] == 3
    with pytest.raises(ValueError, match=r"holds the runs of seeds \[0, 3\]: choose one with run_seed"):
        learned_lib.load(out)
    results = str(tmp_path / "eval")
    assert eval_dcg.main(["evaluate", "--checkpoint", out, "--run-seed", "3", "--episodes", "8", "--out", results,
                          "--no-bound"]) == 0
    assert os.listdir(results) == ["eval_vnn_e8_restricted_run3_s0.json"]
    pictures = str(tmp_path / "pictures")  # render names its pictures by the seed too
    assert eval_dcg.main(["render", "--checkpoint", out, "--run-seed", "3", "--strategy", "restricted",
                          "--max-steps", "3", "--out", pictures]) == 0
    assert sorted(os.listdir(pictures)) == ["dcg_vnn_restricted_run3_s0.gif", "dcg_vnn_restricted_run3_s0.png"]
    capsys.readouterr()
    refused(eval_dcg.main, ["evaluate", "--net", "vnn", "--run-seed", "3", "--out", results], capsys,
            "--run-seed 3 needs --checkpoint")
    refused(eval_dcg.main, ["evaluate", "--checkpoint", out, "--out", results], capsys,
            "choose one with run_seed (eval.dcp's and eval.dcg's --run-seed)")


def test_ship_refuses_several_seeds(capsys, tmp_path):
    _fails(capsys, TINY + ["--out", str(tmp_path / "x"), "--seeds", "0,1", "--ship", str(tmp_path / "n.msgpack")],
           "--ship writes one network")
