"""A Stable-Baselines3 ``VecEnv`` over a jaxdc environment: all copies in one jitted batched step.

SB3 does not accept gymnasium's ``VectorEnv``, and ``make_vec_env`` steps
``num_envs`` single environments one Python call at a time. :class:`JaxdcVecEnv`
steps them with one jitted ``vmap`` of :meth:`~jaxdc.core.env.Environment.step`
(the compiled functions of :mod:`jaxdc.wrappers.batched`, shared with the
gymnasium adapters) and follows SB3's ``VecEnv`` contract:

* ``reset()`` returns the batched first observations; the seed set by
  ``seed(s)`` (SB3 passes ``seed + i`` per copy; the first of them keys the
  whole batch) applies to the next reset, as in SB3;
* ``step_wait()`` returns ``(obs, rewards, dones, infos)`` with auto-reset:
  where ``dones[i]``, ``obs[i]`` is the next episode's first observation,
  ``infos[i]["terminal_observation"]`` the finished one's last,
  ``infos[i]["TimeLimit.truncated"]`` whether the step cap ended it, and
  ``infos[i]["episode"] = {"r", "l", "t"}`` its return, length and wall time
  (what SB3's ``Monitor`` writes, so ``ep_info_buffer`` and the logger's
  ``rollout/ep_rew_mean`` work without a ``VecMonitor``).

Stable-Baselines3 is an optional dependency (the ``bench`` extra)::

    from stable_baselines3 import PPO
    from jaxdc.wrappers.sb3 import make_sb3_vec_env

    venv = make_sb3_vec_env("DCP-v0", num_envs=16, seed=0, risk="low")
    PPO("MlpPolicy", venv, n_steps=64).learn(2048)
"""

from __future__ import annotations

import time
from functools import partial
from typing import Any

import jax
import numpy as np

try:
    from stable_baselines3.common.vec_env import VecEnv
except ImportError as e:  # pragma: no cover - exercised only without the extra
    raise ImportError("jaxdc.wrappers.sb3 needs Stable-Baselines3: pip install 'jaxdc[bench]' "
                      "(or pip install stable-baselines3)") from e

from jaxdc.core.env import Environment
from jaxdc.core.validate import check_positive_int, check_seed
from jaxdc.wrappers import batched

__all__ = ["JaxdcVecEnv", "make_sb3_vec_env"]


class JaxdcVecEnv(VecEnv):
    """``num_envs`` copies of a jaxdc :class:`~jaxdc.core.env.Environment` as one SB3 ``VecEnv``.

    Args:
      env: the functional environment (e.g. ``DCP(...)``, ``DCG(...)``).
      num_envs: the number of copies (>= 1).
      params: its ``EnvParams`` (default ``env.default_params``), checked once here, values included
        (:func:`jaxdc.wrappers.batched.check_params`).
      seed: the seed of the first reset (0 .. 2**32 - 1); ``None`` draws one.
    """

    def __init__(self, env: Environment, num_envs: int, params: Any = None, seed: int | None = 0) -> None:
        self.env = env
        self.params = batched.check_params(env, env.default_params if params is None else params)
        self.render_mode = None
        n = check_positive_int("num_envs", num_envs)
        batched.check_batch_fits(env, self.params, n)
        obs_space, act_space = batched.host_spaces(env, self.params)
        super().__init__(n, obs_space, act_space)
        self._first_seed = None if seed is None else check_seed("seed", seed)
        self._key: jax.Array | None = None
        self._state: Any = None
        self._actions: np.ndarray | None = None
        self._reset_fn = partial(batched.reset, env, n)
        self._step_fn = partial(batched.step, env, n)
        self._started = np.full(n, time.perf_counter())

    # -- the VecEnv interface -------------------------------------------------------------
    def set_options(self, options: list[dict] | dict | None = None) -> None:
        """Set the options of the next reset, as SB3 does; the jaxdc adapters take none
        (:data:`jaxdc.wrappers.batched.RESET_OPTIONS`), so any key is refused here, at once (a ``ValueError`` naming
        it and the allowed keys; nothing is stored), as the gymnasium adapters refuse it in ``reset``."""
        self._check_options(options)
        super().set_options(options)

    def _check_options(self, options: Any) -> None:
        if isinstance(options, (list, tuple)):
            if len(options) != self.num_envs:
                raise ValueError(f"options: a list needs one dict (or None) per copy, {self.num_envs}, "
                                 f"got {len(options)}")
            for i, o in enumerate(options):
                batched.check_reset_options(o, f"options[{i}]")
        else:
            batched.check_reset_options(options)

    def reset(self) -> np.ndarray:
        self._check_options(self._options)  # set_options refuses them; this catches options stored by other means
        seed = self._seeds[0] if self._seeds[0] is not None else self._first_seed
        if seed is None and self._key is None:
            seed = int(np.random.randint(0, 2**31 - 1))
        if seed is not None:
            self._key = jax.random.PRNGKey(check_seed("seed", int(seed)))
        self._first_seed = None
        self._reset_seeds()
        self._reset_options()
        self._key, obs, self._state = self._reset_fn(self._key, self.params)
        self._started[:] = time.perf_counter()
        return np.array(obs, dtype=np.float32)  # a writable copy, as torch wants

    def step_async(self, actions: Any) -> None:
        a = np.asarray(actions).reshape(-1)
        n = int(self.env.num_actions)
        if a.shape != (self.num_envs,) or not np.issubdtype(a.dtype, np.integer) or a.min() < 0 or a.max() >= n:
            raise ValueError(f"actions must be {self.num_envs} ints in [0, {n}), got {actions!r}")
        self._actions = a.astype(np.int32)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        if self._actions is None:
            raise RuntimeError("step_wait() needs the actions of step_async(actions) first (or call step(actions))")
        out = self._step_fn(self._key, self._state, self._actions, self.params)
        self._actions = None  # each step_async is consumed by one step_wait
        self._key, obs, self._state, reward, terminated, truncated, info = out
        obs, reward, terminated, truncated, final, ep_reward, ep_steps = jax.device_get(
            (obs, reward, terminated, truncated, info["final_observation"], info["episode_reward"],
             info["episode_steps"]))
        terminated, truncated = np.asarray(terminated, bool), np.asarray(truncated, bool)
        done = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        now = time.perf_counter()
        for i in np.flatnonzero(done):
            infos[i] = {
                "terminal_observation": np.asarray(final[i], np.float32),
                "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                "episode": {"r": float(ep_reward[i]), "l": int(ep_steps[i]), "t": round(now - self._started[i], 6)},
            }
            self._started[i] = now
        return np.array(obs, dtype=np.float32), np.array(reward, dtype=np.float32), done, infos  # writable copies

    def close(self) -> None:
        self._state = None

    def get_attr(self, attr_name: str, indices: Any = None) -> list:
        return [getattr(self, attr_name)] * len(list(self._get_indices(indices)))

    #: Attributes fixed at construction (the compiled batch and the spaces SB3 sized its networks by).
    READ_ONLY = ("env", "num_envs", "observation_space", "action_space")

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Set an attribute of the vector env. ``params`` (shared by all copies, so ``indices`` must name all
        of them) go through :func:`jaxdc.wrappers.batched.check_params` (kind, shapes and values) and must keep the
        spaces;
        :data:`READ_ONLY` attributes are refused."""
        if attr_name in self.READ_ONLY:
            raise ValueError(f"set_attr: {attr_name!r} is fixed at construction; build a new JaxdcVecEnv instead")
        if attr_name == "params":
            idx = sorted({int(i) for i in self._get_indices(indices)})
            if idx != list(range(self.num_envs)):
                raise ValueError(f"set_attr: 'params' are shared by all {self.num_envs} copies; indices must "
                                 f"name all of them, got {indices!r}")
            value = batched.check_params(self.env, value)
            obs_space, act_space = batched.host_spaces(self.env, value)
            if obs_space != self.observation_space or act_space != self.action_space:
                raise ValueError("set_attr: these 'params' change the observation or action space "
                                 f"({obs_space}, {act_space} instead of {self.observation_space}, "
                                 f"{self.action_space}); build a new JaxdcVecEnv instead")
        setattr(self, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any) -> list:
        method = getattr(self.env, method_name)
        return [method(*method_args, **method_kwargs)] * len(list(self._get_indices(indices)))

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False] * len(list(self._get_indices(indices)))


def make_sb3_vec_env(env_id: str = "DCP-v0", num_envs: int = 8, seed: int | None = 0, **kwargs: Any) -> JaxdcVecEnv:
    """:class:`JaxdcVecEnv` of a registered jaxdc environment (``jaxdc.make(env_id, **kwargs)``)."""
    from jaxdc import make

    env, params = make(env_id, **kwargs)
    return JaxdcVecEnv(env, num_envs, params, seed)
