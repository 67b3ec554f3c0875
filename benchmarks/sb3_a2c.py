"""The Stable-Baselines3 side of ``benchmarks/train_throughput.py``: SB3's A2C on the DCP, sized and tuned like
jaxdc's (section 4.5's body in PyTorch, the same rollout length ``T_MAX``, Adam), timed in a fresh interpreter per
thread setting (``train_throughput.py --_sb3-child``). Imports torch and SB3 only when called.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The rollout length of every trainer the benchmark times (jaxdc's A2C and SB3's ``n_steps``).
T_MAX = 32
#: The DCP of the benchmark, for SB3's gymnasium.make (same as ``make_env("dcp")``).
GYM_KWARGS = {"grid_size": 8, "total_reward": 30, "risk": "high", "energy": (8.0, 16.0), "max_steps": 200}


def sb3_body_class():
    """The SB3 features extractor ``SB3ConvBody``: section 4.5's body in PyTorch (imports torch)."""
    import torch
    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

    class SB3ConvBody(BaseFeaturesExtractor):
        """``obs [B, N, N, C] -> [B, 256]``: conv 3x3 32 -> conv 3x3 16 (same) -> dense 256, ReLU."""

        def __init__(self, observation_space, features_dim: int = 256):
            super().__init__(observation_space, features_dim)
            n, m, c = observation_space.shape
            self.net = torch.nn.Sequential(
                torch.nn.Conv2d(c, 32, 3, padding=1), torch.nn.ReLU(),
                torch.nn.Conv2d(32, 16, 3, padding=1), torch.nn.ReLU(), torch.nn.Flatten(),
                torch.nn.Linear(16 * n * m, features_dim), torch.nn.ReLU())

        def forward(self, obs):
            return self.net(obs.permute(0, 3, 1, 2))

    return SB3ConvBody


def make_sb3_a2c(num_envs: int, vec_env: str = "dummy", seed: int = 0):
    """SB3 A2C on the DCP sized and tuned like jaxdc's (see the module docs).

    ``vec_env``: ``"dummy"``, ``make_vec_env("jaxdc/DCP-v0")`` (one jitted env call per env
    and step, what a user gets), or ``"jaxvec"``, :class:`jaxdc.wrappers.sb3.JaxdcVecEnv` (one jitted call for
    all envs per step).
    """
    import torch
    from stable_baselines3 import A2C
    from stable_baselines3.common.env_util import make_vec_env

    import jaxdc  # noqa: F401  (registers the id)

    if vec_env == "jaxvec":
        from jaxdc.wrappers.sb3 import make_sb3_vec_env

        venv = make_sb3_vec_env("DCP-v0", num_envs, seed, **GYM_KWARGS)
    else:  # render_mode=None: make_vec_env asks for "rgb_array" unless told otherwise
        venv = make_vec_env("jaxdc/DCP-v0", n_envs=num_envs, seed=seed,
                            env_kwargs={**GYM_KWARGS, "render_mode": None})
    policy_kwargs = {"features_extractor_class": sb3_body_class(), "net_arch": [],
                     "optimizer_class": torch.optim.Adam, "optimizer_kwargs": {"betas": (0.9, 0.999)}}
    return A2C("MlpPolicy", venv, n_steps=T_MAX, learning_rate=1e-4, gamma=0.99, ent_coef=0.01, vf_coef=1.0,
               use_rms_prop=False, policy_kwargs=policy_kwargs, seed=seed, device="cpu", verbose=0)


def sb3_child(num_envs: int, threads: str, vec_env: str, chunk_steps: int, repeats: int) -> dict:
    """Time SB3 A2C learning (and its vectorized env alone) in this process."""
    import numpy as np
    import stable_baselines3
    import torch

    if threads == "1":
        torch.set_num_threads(1)
    model = make_sb3_a2c(num_envs, vec_env)
    batch = num_envs * T_MAX
    n = max(1, math.ceil(chunk_steps / batch)) * batch
    t0 = time.perf_counter()
    model.learn(batch)  # warm-up: the first rollout and update
    first = time.perf_counter() - t0
    best, cpu = math.inf, math.inf
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        model.learn(n, reset_num_timesteps=False)
        best, cpu = min((best, cpu), (time.perf_counter() - t0, time.process_time() - c0))
    venv, rng = model.get_env(), np.random.default_rng(0)
    venv.reset()
    env_best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n // num_envs):
            venv.step(rng.integers(0, 9, num_envs))
        env_best = min(env_best, time.perf_counter() - t0)
    return {"impl": f"sb3 a2c {vec_env}", "layout": "-", "threads": f"{threads} ({torch.get_num_threads()})",
            "num_envs": num_envs, "env_steps": n, "seconds": best, "compile_s": max(first - best * batch / n, 0.0),
            "steps_per_s": n / best, "cpu_s": cpu, "steps_per_cpu_s": n / cpu, "env_only_steps_per_s": n / env_best,
            "torch": torch.__version__, "torch_cuda": torch.version.cuda, "sb3": stable_baselines3.__version__}


def bench_sb3(num_envs: int, threads: str, vec_env: str, chunk_steps: int, repeats: int) -> dict:
    """:func:`sb3_child` in a fresh interpreter with the thread setting in its environment."""
    env = dict(os.environ)
    for k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env.pop(k, None)
        if threads == "1":
            env[k] = "1"
    cmd = [sys.executable, str(ROOT / "benchmarks" / "train_throughput.py"), "--_sb3-child", threads,
           "--sb3-vec-envs", vec_env, "--envs", str(num_envs), "--chunk-steps", str(chunk_steps),
           "--repeats", str(repeats)]
    out = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env)
    if out.returncode != 0:
        raise RuntimeError(f"SB3 subprocess failed ({' '.join(cmd)}):\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def sb3_available() -> bool:
    try:
        import stable_baselines3  # noqa: F401
        import torch  # noqa: F401
    except ImportError:
        return False
    return True
