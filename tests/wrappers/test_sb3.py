"""jaxdc.wrappers.sb3: the batched Stable-Baselines3 VecEnv (contract, determinism) and SB3 PPO on DCP and DCG.

Behind the ``sb3`` marker; ``.ci/run`` sets ``JAXDC_REQUIRE_SB3=1`` so that a missing SB3 fails instead of skipping.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.support.sb3_required import require_sb3  # noqa: E402

pytestmark = pytest.mark.sb3

require_sb3()

from jaxdc.wrappers.sb3 import JaxdcVecEnv, make_sb3_vec_env  # noqa: E402

GRID = 4
DCP_KW = {"grid_size": GRID, "total_reward": 10, "risk": np.zeros((GRID, GRID), np.float32),
          "energy": (20.0, 20.0), "max_steps": 16}


def _play(venv, steps, seed=0):
    rng = np.random.default_rng(seed)
    out = [venv.reset()]
    for _ in range(steps):
        venv.step_async(rng.integers(0, 9, venv.num_envs))
        out.append(venv.step_wait())
    return out


def test_vec_env_contract_autoreset_and_episode_info():
    venv = make_sb3_vec_env("DCP-v0", num_envs=6, seed=3, **DCP_KW)
    assert venv.observation_space.shape == (GRID, GRID, 2) and np.all(np.isfinite(venv.observation_space.high))
    played = _play(venv, 60)
    obs0 = played[0]
    assert obs0.shape == (6, GRID, GRID, 2) and obs0.flags.writeable
    returns = np.zeros(6)
    ended = 0
    for obs, reward, done, infos in played[1:]:
        assert obs.dtype == np.float32 and reward.shape == (6,) and done.dtype == bool
        returns += reward
        for i in np.flatnonzero(done):
            info = infos[i]
            assert info["terminal_observation"].shape == (GRID, GRID, 2)
            assert info["episode"]["r"] == pytest.approx(returns[i]) and info["episode"]["l"] <= 16
            assert isinstance(info["TimeLimit.truncated"], bool)
            returns[i] = 0.0
            ended += 1
        for i in np.flatnonzero(~done):
            assert infos[i] == {}
    assert ended >= 6  # 16-step episodes: every copy finished at least once in 60 steps


def test_same_seed_same_trajectory_and_seed_method():
    a = _play(make_sb3_vec_env("DCP-v0", num_envs=4, seed=11, **DCP_KW), 20)
    b = _play(make_sb3_vec_env("DCP-v0", num_envs=4, seed=11, **DCP_KW), 20)
    np.testing.assert_array_equal(a[0], b[0])
    for x, y in zip(a[1:], b[1:]):
        np.testing.assert_array_equal(x[0], y[0])
        np.testing.assert_array_equal(x[1], y[1])
    venv = make_sb3_vec_env("DCP-v0", num_envs=4, seed=None, **DCP_KW)
    venv.seed(11)
    np.testing.assert_array_equal(venv.reset(), a[0])


def test_bad_actions_and_arguments_are_refused():
    venv = make_sb3_vec_env("DCP-v0", num_envs=3, **DCP_KW)
    venv.reset()
    for bad in ([0, 1, 9], [0, 1], [0.5, 1, 2], [-1, 0, 0]):
        with pytest.raises(ValueError, match="actions must be 3 ints in"):
            venv.step_async(np.asarray(bad))
    with pytest.raises(ValueError, match="num_envs"):
        make_sb3_vec_env("DCP-v0", num_envs=0)
    with pytest.raises(ValueError, match="seed"):
        make_sb3_vec_env("DCP-v0", num_envs=2, seed=2**40)


@pytest.mark.slow
def test_ppo_learns_on_dcp_and_trains_on_dcg():
    import torch
    from stable_baselines3 import PPO

    torch.set_num_threads(1)
    venv = make_sb3_vec_env("DCP-v0", num_envs=8, seed=0, **DCP_KW)
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=128, n_epochs=4, learning_rate=3e-3, gamma=0.95,
                ent_coef=0.0, policy_kwargs={"net_arch": [64, 64]}, seed=0, device="cpu", verbose=0)
    model.learn(4096)
    first = [e["r"] for e in list(model.ep_info_buffer)[:20]]
    # the learned policy against random actions on the same 64 fresh episodes (one batched rollout each)
    def returns(act):
        venv_eval = JaxdcVecEnv(venv.env, 64, venv.params, seed=123)
        obs, total, done_once = venv_eval.reset(), np.zeros(64), np.zeros(64, bool)
        rng = np.random.default_rng(0)
        while not done_once.all():
            venv_eval.step_async(act(obs, rng))
            obs, r, done, _ = venv_eval.step_wait()
            total += np.where(done_once, 0.0, r)
            done_once |= done
        return total
    learned = returns(lambda obs, rng: model.predict(obs, deterministic=False)[0])
    random = returns(lambda obs, rng: rng.integers(0, 9, 64))
    assert len(model.ep_info_buffer) > 0 and np.isfinite(first).all()
    assert learned.mean() > 1.25 * random.mean(), (learned.mean(), random.mean())

    dcg = make_sb3_vec_env("DCG-v0", num_envs=8, seed=0, grid_size=4, total_reward=3, max_steps=20)
    PPO("MlpPolicy", dcg, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu", verbose=0).learn(512)
