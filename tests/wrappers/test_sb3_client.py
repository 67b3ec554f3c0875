"""A real client: Stable-Baselines3 PPO learns on ``jaxdc/DCP-v0`` through the gymnasium wrapper.

Behind the ``sb3`` marker and ``pytest.importorskip``: the default dev install has no
PyTorch. ``.ci/run`` installs the ``bench`` extra and sets ``JAXDC_REQUIRE_SB3=1``, which
turns a missing Stable-Baselines3 into a failure instead of a skip.

The setting is small and easy so that a few thousand steps suffice: a 4 x 4 grid, 10
units of reward, no risk, energy 20 (never binding), 16 steps per episode. What is learnt is the
core of the DCP (section 4.3): move onto the cells that hold items. Both policies are
evaluated on the same fixed episode seeds (same item drops and start cells).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from tests.support.sb3_required import require_sb3

pytestmark = pytest.mark.sb3

require_sb3()

import gymnasium  # noqa: E402

import jaxdc  # noqa: E402,F401  (registers jaxdc/DCP-v0)

GRID = 4
KWARGS = {"grid_size": GRID, "total_reward": 10, "risk": np.zeros((GRID, GRID), np.float32),
          "energy": (20.0, 20.0), "max_steps": 16}
TRAIN_STEPS = int(os.environ.get("JAXDC_SB3_STEPS", 4096))
EVAL_SEEDS = range(10_000, 10_200)


def _returns(env, act) -> np.ndarray:
    """Undiscounted return of one episode per seed in :data:`EVAL_SEEDS`, actions from ``act(obs, rng)``."""
    out = []
    for seed in EVAL_SEEDS:
        obs, _ = env.reset(seed=seed)
        rng, total, done = np.random.default_rng(seed), 0.0, False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(act(obs, rng))
            total += reward
            done = terminated or truncated
        out.append(total)
    return np.asarray(out)


def test_ppo_learns_above_random_on_dcp():
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    torch.set_num_threads(1)  # small network: one thread is fastest (benchmarks/train_throughput.py)
    venv = make_vec_env("jaxdc/DCP-v0", n_envs=4, seed=0, env_kwargs={**KWARGS, "render_mode": None})
    model = PPO("MlpPolicy", venv, n_steps=128, batch_size=128, n_epochs=4, learning_rate=3e-3, gamma=0.95,
                ent_coef=0.0, policy_kwargs={"net_arch": [64, 64]}, seed=0, device="cpu", verbose=0)
    model.learn(TRAIN_STEPS)

    env = gymnasium.make("jaxdc/DCP-v0", **KWARGS)
    learned = _returns(env, lambda obs, rng: int(model.predict(obs, deterministic=False)[0]))
    random = _returns(env, lambda obs, rng: int(rng.integers(0, 9)))
    # Paired by seed: the same items and start cell for both policies.
    diff = learned - random
    se = diff.std(ddof=1) / np.sqrt(len(diff))
    print(f"PPO {learned.mean():.2f} vs random {random.mean():.2f} per episode; "
          f"paired difference {diff.mean():.2f} +- {se:.2f} (SE, {len(diff)} seeds)")
    assert np.all(np.isfinite(learned)) and learned.min() >= 0
    assert diff.mean() > 4 * se, (learned.mean(), random.mean(), se)  # z > 4 on the paired difference
    assert learned.mean() > 1.25 * random.mean()
