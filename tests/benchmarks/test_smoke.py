"""Smoke test of benchmarks/env_throughput.py and the rules of the NumPy DCP baseline."""

from __future__ import annotations

import contextlib
import io
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from benchmarks import env_throughput, numpy_dcp
from jaxdc.dcp.env import CLEARED, DCP, ENERGY, IDLE, RISK, RUNNING, TRUNCATED

UP, UP_LEFT, RIGHT, STAY = 1, 5, 4, 0


def _env(risk=None, **kw):
    risk = np.zeros((8, 8), np.float32) if risk is None else risk
    return numpy_dcp.NumpyDCP(risk=risk, energy=(8.0, 16.0), **kw)


def _set(env, pos, energy, items):
    env.pos = np.array(pos, np.int64)
    env.energy = float(energy)
    env.items = np.zeros((8, 8))
    for (r, c), v in items.items():
        env.items[r, c] = v
    env.time, env.outcome, env.ep_reward, env.ep_energy = 0, RUNNING, 0.0, 0


def _jax_step(env, action):
    """The same transition with the JAX env (zero/one risks make it deterministic)."""
    jenv = DCP(total_reward=30, idle_terminates=env.idle_terminates)
    params = jenv.make_params(env.risk.astype(np.float32), (8.0, 16.0), max_steps=env.max_steps)
    _, state = jenv.reset_env(jax.random.key(0), params)  # then overwrite the fields the rules read
    state = state.replace(pos=jnp.asarray(env.pos, jnp.int32), energy=jnp.float32(env.energy),
                          items=jnp.asarray(env.items, jnp.float32), time=jnp.int32(env.time),
                          outcome=jnp.int32(RUNNING), ep_reward=jnp.float32(0), ep_energy=jnp.int32(0))
    _, s, reward, term, trunc, _ = jenv.step_env(jax.random.key(0), state, action, params)
    return s, float(reward), bool(term), bool(trunc)


def test_numpy_collect_clip_and_agreement_with_jax():
    env, rng = _env(), np.random.default_rng(0)
    _set(env, (2, 2), 5, {(1, 1): 3.0, (5, 5): 1.0})
    js, jr, jterm, jtrunc = _jax_step(env, UP_LEFT)
    obs, reward, term, trunc = env.step_env(rng, UP_LEFT)
    assert reward == 3.0 == jr and not term and not trunc and not jterm
    assert env.pos.tolist() == [1, 1] == np.asarray(js.pos).tolist()
    assert env.energy == 4.0 == float(js.energy) and env.items[1, 1] == 0 and env.ep_energy == 1
    np.testing.assert_array_equal(env.items, np.asarray(js.items))
    assert obs[1, 1, 1] == 4.0 and obs[..., 1].sum() == 4.0 and obs[5, 5, 0] == 1.0
    # Clipped per axis: up_left on the top edge still moves left.
    _set(env, (0, 3), 5, {(5, 5): 1.0})
    env.step_env(rng, UP_LEFT)
    assert env.pos.tolist() == [0, 2]


def test_numpy_base_refill_idle_energy_risk_cleared_truncated():
    rng = np.random.default_rng(0)
    env = _env(idle_terminates=True)
    _set(env, (1, 1), 1, {(5, 5): 1.0})  # energy 1, but entering the base refills
    _, _, term, _ = env.step_env(rng, UP_LEFT)
    assert env.pos.tolist() == [0, 0] and env.energy == 16.0 and not term and env.ep_energy == 1
    _, _, term, _ = env.step_env(rng, STAY)  # stays in the base: no energy used, state unchanged
    assert term and env.outcome == IDLE and env.ep_energy == 1

    _set(env, (3, 3), 1, {(5, 5): 1.0})
    js = _jax_step(env, RIGHT)[0]
    _, _, term, _ = env.step_env(rng, RIGHT)
    assert term and env.outcome == ENERGY == int(js.outcome)

    risk = np.zeros((8, 8), np.float32)
    risk[2, 3] = 1.0
    env = _env(risk)
    _set(env, (3, 3), 5, {(5, 5): 1.0})
    js = _jax_step(env, UP)[0]
    _, _, term, _ = env.step_env(rng, UP)
    assert term and env.outcome == RISK == int(js.outcome)

    _set(env, (4, 4), 5, {(5, 5): 2.0})
    _, reward, term, _ = env.step_env(rng, 8)  # down_right onto the last item
    assert term and reward == 2.0 and env.outcome == CLEARED and env.ep_reward == 2.0

    env = _env(max_steps=1)
    _set(env, (4, 4), 5, {(6, 6): 1.0})
    _, _, term, trunc = env.step_env(rng, STAY)
    assert trunc and not term and env.outcome == TRUNCATED


def test_numpy_reset_and_auto_reset():
    rng = np.random.default_rng(1)
    env = _env(items_on_base=False)
    for _ in range(20):
        env.reset(rng)
        assert env.items.sum() == 30 and env.items[0, 0] == 0
        assert env.items[env.pos[0], env.pos[1]] == 0  # random_free start
    risk = np.ones((8, 8), np.float32)
    risk[0, 0] = 0.0
    env = _env(risk)
    env.reset(rng)
    if env.pos.tolist() == [0, 0]:
        env.pos = np.array([1, 1])
    obs, _, term, _, final = env.step(rng, RIGHT)  # certain risk -> auto-reset
    assert term and env.time == 0 and env.outcome == RUNNING and obs[..., 0].sum() == 30
    assert final is not obs


def test_benchmark_main_quick(tmp_path, capsys):
    result = env_throughput.main(["--json", "--batch-sizes", "1", "4", "--steps", "5", "--quick",
                                  "--no-table43", "--out-dir", str(tmp_path)])
    out = capsys.readouterr().out.strip()
    assert json.loads(out) == json.loads(json.dumps(result))  # exactly one JSON object on stdout
    impls = [(r["impl"], r["batch"]) for r in result["rows"]]
    slots = "jax_random [reset_slots=B/4]"
    assert impls == [("jax_random", 1), (slots, 1), ("jax_batched", 1), ("jax_random", 4), (slots, 4),
                     ("jax_batched", 4), ("jax_safe_reward", 1),
                     ("jax_dcg_random", 1), ("jax_dcg_batched", 1), ("jax_dcg_team_random", 1),
                     ("jax_dcg_team_batched", 1), ("jax_handbatched", 1), ("numpy_batched", 1), ("numpy_loop", 1)]
    for r in result["rows"]:
        assert r["steps_per_s"] > 0 and r["env_steps"] == r["batch"] * r["steps"]
        assert set(r) >= {"impl", "batch", "steps", "seconds", "compile_s", "steps_per_s", "vs_numpy"}
    assert json.loads((tmp_path / "env_throughput.json").read_text())["rows"] == result["rows"]
    md = (tmp_path / "env_throughput.md").read_text()
    assert md.startswith("`python benchmarks/env_throughput.py --json --batch-sizes 1 4 --steps 5 --quick")
    assert "\n| implementation | batch | T | env-steps/s |" in md and md.count("| jax_random |") == 2
    assert "load average" in md and result["machine"]["loadavg_1min_start"] >= 0
    assert not list(tmp_path.glob(".tmp-*"))

    # The Table 4.3 and target sections, on a synthetic result (compiling them costs ~20 s).
    fake = dict(result)
    fake["rows"] = result["rows"] + [dict(r, batch=4096, steps_per_s=v) for r, v in
                                     ((result["rows"][0], 3.0), (result["rows"][-3], 4.0), (result["rows"][-2], 2.0),
                                      (result["rows"][2], 2.2))]
    fake["table43"] = {"episodes": 10_000, "compile_s": 4.0, "run_s": 2.0,
                       "navigators": {n: {"compile_s": 1.0, "run_s": 0.5, "episode_steps": 10}
                                      for n in env_throughput.TABLE43_NAVIGATORS}}
    fake["targets"] = env_throughput.targets(fake)
    assert fake["targets"]["table43_lt_5s"]["met"] and "random_4096_ge_5M" in fake["targets"]
    assert fake["targets"]["random_4096_share_of_handbatched"]["value"] == 0.75
    assert fake["targets"]["random_4096_over_numpy_batched"] == {"value": 1.5, "target": 1.0, "met": True}
    assert fake["rows"][-1]["impl"] == "jax_batched"  # issue 30: >= 1.2x numpy_batched (2.2 / 2.0 = 1.1: not met)
    assert fake["targets"]["batched_4096_over_numpy_batched"]["target"] == 1.2
    assert not fake["targets"]["batched_4096_over_numpy_batched"]["met"]
    assert fake["targets"]["batched_4096_share_of_handbatched"]["value"] == pytest.approx(0.55)
    md = env_throughput.markdown(fake)
    assert "| **total** | 4.00 | 2.000 |" in md and "table43_lt_5s" in md


# -- benchmarks/train_throughput.py ----------------------------------------------------------
@pytest.fixture(scope="module")
def quick_throughput(tmp_path_factory):
    """One --quick run with the PPO-style row asked for: its plain CNN row is what a --quick run alone gives
    (the --ppo-envs row is appended after it), so the two tests below read one run instead of running the CNN
    row twice. Returns (result, stdout, out_dir)."""
    from benchmarks import train_throughput as tt

    out_dir = tmp_path_factory.mktemp("train_throughput")
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        result = tt.main(["--json", "--quick", "--envs", "2", "--nets", "cnn", "--layouts", "loop", "--no-sb3",
                          "--ppo-envs", "2", "--out-dir", str(out_dir)])
    return result, stdout.getvalue(), out_dir


def test_train_throughput_quick(quick_throughput):
    from benchmarks import train_throughput as tt

    result, out, tmp_path = quick_throughput
    assert json.loads(out.strip()) == json.loads(json.dumps(result))  # exactly one JSON object on stdout
    row = result["rows"][0]
    assert (row["impl"], row["layout"], row["num_envs"]) == ("jaxdc cnn", "loop", 2)
    assert row["env_steps"] == 2 * tt.T_MAX and row["steps_per_s"] > 0 and row["gflops"] > 0
    assert result["comparisons"] == [] and "sb3" in result
    assert result["flops"]["cnn_train_per_sample"] == 4 * result["flops"]["cnn_forward_per_sample"]
    assert json.loads((tmp_path / "train_throughput.json").read_text())["rows"] == result["rows"]
    md = (tmp_path / "train_throughput.md").read_text()
    assert md.startswith("`python benchmarks/train_throughput.py --json --quick") and "| jaxdc cnn | loop |" in md
    assert not list(tmp_path.glob(".tmp-*")) and not (tmp_path / "train_throughput.partial.json").exists()


def test_train_throughput_partial_rows_record_provenance(tmp_path):
    import jaxdc
    from benchmarks import train_throughput as tt

    tt._save_partial(tmp_path, [{"impl": "jaxdc cnn", "steps_per_s": 1.0}])
    saved = json.loads((tmp_path / "train_throughput.partial.json").read_text())
    assert saved["rows"] == [{"impl": "jaxdc cnn", "steps_per_s": 1.0}]
    assert saved["provenance"]["jaxdc_version"] == jaxdc.__version__ and "command" in saved["provenance"]


def test_train_throughput_ppo_row(quick_throughput):
    """The PPO-style row: the options of docs/learning.md (4 x 4 Adam steps per update), only when asked for in
    --quick."""
    from benchmarks import train_throughput as tt

    assert tt.parse_args(["--quick"]).ppo_envs == [] and tt.parse_args([]).ppo_envs == [32]
    assert tt.parse_args(["--ppo-envs"]).ppo_envs == []
    assert tt.make_trainer("enn", 2, options=tt.ppo_options()).config.steps_per_update == 16
    result, _, tmp_path = quick_throughput
    assert [(r["impl"], r["num_envs"]) for r in result["rows"]] == [("jaxdc cnn", 2), ("jaxdc enn ppo", 2)]
    assert result["rows"][1]["env_steps"] == 2 * tt.T_MAX and result["config"]["ppo_options"] == {
        "lr": 3e-4, "clip_eps": 0.2, "epochs": 4, "minibatches": 4, "gae_lambda": 0.95, "normalize_advantages": True,
        "reset_slots": 4}
    assert "| jaxdc enn ppo | loop |" in (tmp_path / "train_throughput.md").read_text()


def test_train_throughput_flops_and_ratios():
    from benchmarks import train_throughput as tt

    # 8x8x2 planes: conv 32 (1,152 weights x 64 cells), conv 16 (4,608 x 64), dense 1,024 x 256, heads 256 x 10.
    assert tt.flops_per_sample()["forward"] == 2 * (64 * 32 * 18 + 64 * 16 * 288 + 1024 * 256 + 2560)
    assert 4.7e6 < tt.flops_per_sample()["train"] < 4.8e6  # the "about 4.7 MFLOP per sample"

    def row(impl, threads, rate, layout="-"):
        return {"impl": impl, "layout": layout, "threads": threads, "num_envs": 16, "compile_s": 10.0,
                "steps_per_s": rate}

    rows = [row("jaxdc enn", "xla", 6000.0, "loop"), row("jaxdc enn", "xla", 3000.0, "scan"),
            row("sb3 a2c dummy", "default (2)", 500.0), row("sb3 a2c dummy", "1 (1)", 1000.0),
            row("sb3 a2c jaxvec", "default (2)", 1500.0), row("sb3 a2c jaxvec", "1 (1)", 4000.0)]
    (c,) = tt.comparisons(rows)
    assert c["layout"] == "loop" and c["vs"] == {"dummy/default": 12.0, "dummy/1": 6.0, "jaxvec/default": 4.0,
                                                 "jaxvec/1": 1.5}
    assert c["vs_sb3_fastest"] == 1.5 and c["vs_sb3_default"] == 12.0
    t = tt.targets({"rows": rows, "comparisons": [c]})
    assert t["enn@16_ge_8x_sb3_default"]["met"] and not t["enn@16_ge_2x_sb3_fastest"]["met"]
    assert t["enn_1M_steps_le_3min (16 envs)"]["met"]  # 1e6 / 6000 + 10 s compile = 177 s


def test_train_throughput_bad_input():
    from benchmarks import train_throughput as tt

    for argv in (["--envs", "0"], ["--repeats", "0"], ["--cpu-gflops", "-1"], ["--nets", "eqn"], ["--ppo-envs", "0"]):
        with pytest.raises(SystemExit):
            tt.parse_args(argv)


def test_train_throughput_sb3_child_jaxvec():
    """SB3's side on a tiny setting, in this process (the benchmark runs it in a subprocess)."""
    pytest.importorskip("torch")
    pytest.importorskip("stable_baselines3")
    from benchmarks import train_throughput as tt

    r = tt.sb3_child(2, "1", "jaxvec", chunk_steps=1, repeats=1)
    assert r["impl"] == "sb3 a2c jaxvec" and r["threads"] == "1 (1)" and r["env_steps"] == 2 * tt.T_MAX
    assert r["steps_per_s"] > 0 and r["env_only_steps_per_s"] > 0 and r["torch_cuda"] is None  # a CPU build


if __name__ == "__main__":
    raise SystemExit(pytest.main([__file__, "-q"]))


def test_the_baselines_play_the_library_rules():
    """The yardsticks of env_throughput.py collect the same mean reward per step as the library's DCP under a
    random policy (200k steps each; a rule left out, e.g. the risk or the refill, moves it by far more)."""
    from benchmarks import handbatched_dcp
    from jaxdc.core import grid

    env, params = env_throughput.make_env("dcp")
    lib = float(env_throughput.make_rollout(env, params, 500, 400, "random")(jax.random.PRNGKey(3))[2]) / 200_000
    batched = float(env_throughput.make_rollout(env, params, 500, 400, "random", batched=True)(
        jax.random.PRNGKey(7))[2]) / 200_000
    hand = handbatched_dcp.make_rollout(grid.as_risk_map("high", 8), (8.0, 16.0), 200, 30, 500, 400)
    rates = {"jax_batched": batched, "jax_handbatched": float(hand(jax.random.PRNGKey(4))[1]) / 200_000,
             "numpy_batched": numpy_dcp.batched_rollout(numpy_dcp.BatchedNumpyDCP(500), np.random.default_rng(5),
                                                        400) / 200_000,
             "numpy_loop": numpy_dcp.plain_loop(np.random.default_rng(6), 200_000) / 200_000}
    assert 0.2 < lib < 0.4
    for name, rate in rates.items():
        assert abs(rate - lib) < 0.015, (name, rate, lib)
