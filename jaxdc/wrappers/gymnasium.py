"""Gymnasium adapters for the functional jaxdc environments.

* :class:`JaxToGymnasium` -- one environment as a stateful :class:`gymnasium.Env`.
  ``step`` calls the jitted ``env.step_env`` (no auto-reset: gymnasium users
  call ``reset`` themselves).
* :class:`JaxVectorEnv` -- ``num_envs`` copies behind one jitted, vmapped
  ``env.step`` with jaxdc's *same-step* auto-reset
  (``metadata["autoreset_mode"] == AutoresetMode.SAME_STEP``): when a copy's
  episode ends, the returned observation is already the first one of its next
  episode and the last one of the finished episode is in ``info["final_obs"]``
  (mask ``info["_final_obs"]``).

Key scheme (both classes): ``reset(seed=s)`` sets ``key = PRNGKey(s)``; every
``reset``/``step`` then does ``key, sub = jax.random.split(key)`` and uses
``sub`` (the vector env splits ``sub`` into ``num_envs`` keys). A reset
without a seed continues the stream; the very first unseeded reset draws the
seed from gymnasium's ``np_random``.

``make_dcp`` / ``make_dcp_vector`` are the entry points registered as
``"jaxdc/DCP-v0"``, ``make_dcg`` / ``make_dcg_vector`` those of
``"jaxdc/DCG-v0"`` (see :mod:`jaxdc`). The adapters know no problem: they call
the environment's hooks (:class:`~jaxdc.core.env.Environment`). ``render_mode="ansi"``:
its ``render_ansi(state, params)``; ``render_mode="rgb_array"``: a ``uint8 [H, W, 3]``
picture of its ``scene(state, params)`` by :func:`jaxdc.viewer.render_frame` (for the
DCP and DCG: risk field, base, agent and energy, items, opponent, fog); ``info["outcome"]``:
a name from its ``outcomes``. The compiled steps are those of :mod:`jaxdc.wrappers.batched`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import gymnasium
import jax
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from jaxdc.core.env import Environment, writes
from jaxdc.core.validate import check_positive_int, check_seed
from jaxdc.wrappers import batched

RENDER_MODES = ("ansi", "rgb_array")

__all__ = ["JaxToGymnasium", "JaxVectorEnv", "make_dcp", "make_dcp_vector", "make_dcg", "make_dcg_vector",
           "RENDER_MODES"]


def _check_render_mode(render_mode: str | None, env: Environment | None = None) -> str | None:
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(f"render_mode must be None or one of {list(RENDER_MODES)}, got {render_mode!r}")
    if env is not None and render_mode is not None:
        hook = _HOOKS[render_mode]
        if not writes(env, hook):
            other = [m for m in RENDER_MODES if m != render_mode and writes(env, _HOOKS[m])]
            raise ValueError(f"render_mode={render_mode!r} needs an environment that writes {hook}(state, params) "
                             f"(as the DCP and DCG do); {type(env).__name__} does not"
                             + (f"; use render_mode={other[0]!r}" if other else ""))
    return render_mode


#: The Environment hook each render mode calls.
_HOOKS = {"ansi": "render_ansi", "rgb_array": "scene"}


def _outcome_names(env: Environment, outcome_names: Sequence[str] | None) -> tuple[str, ...] | None:
    if outcome_names is not None:
        return tuple(outcome_names)
    return None if env.outcomes is None else tuple(env.outcomes)


def _renderer(env: Environment, render_mode: str = "ansi") -> Callable[[Any, Any], Any]:
    """``render(state, params)`` for ``render_mode``: :func:`jaxdc.viewer.render_frame` (which draws the env's
    :meth:`~jaxdc.core.env.Environment.scene`) for ``"rgb_array"``, the env's ``render_ansi`` for ``"ansi"``."""
    if render_mode == "rgb_array":
        from jaxdc.viewer import render_frame

        return lambda state, params: render_frame(env, params, state)
    return env.render_ansi


def _check_action(action: Any, num_actions: int) -> np.int32:
    try:
        a = np.asarray(action)
        ok = a.shape == () and np.issubdtype(a.dtype, np.integer) and 0 <= int(a) < num_actions
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"action must be an int in [0, {num_actions}), got {action!r}")
    return np.int32(a)


class _KeyedReset:
    """The key scheme shared by both adapters: ``reset(seed=s)`` restarts the key stream at
    ``PRNGKey(s)``; every reset and step then splits off a subkey. A reset without a seed
    continues the stream (the very first one draws its seed from gymnasium's ``np_random``)."""

    # set by the adapter's constructor
    env: Environment
    params: Any
    render_mode: str | None
    np_random: np.random.Generator
    _key: jax.Array | None
    _state: Any
    _ended: str | None = None  # "terminated"/"truncated" once the single env's episode ended, until reset()
    _reset_fn: Callable[..., Any]
    _step_fn: Callable[..., Any]

    @property
    def state(self) -> Any:
        """The current functional state, batched for the vector env (``None`` before the first reset)."""
        return self._state

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Start new episodes (see the key scheme above). The adapters take no reset ``options``: any key is
        refused (``ValueError`` naming it), so a misspelt or unsupported option is never silently ignored.

        The seed and the options are checked before anything changes: a refused reset leaves the key, the state
        and ``np_random`` as they were. (Through ``gymnasium.make``, gymnasium's ``PassiveEnvChecker`` -- unless
        the id is registered with ``disable_env_checker=True`` -- marks its first reset as done *before* calling
        this one, so after a refused first reset its first ``step`` fails inside the checker with ``TypeError:
        cannot unpack non-iterable NoneType object``; nothing here can undo the checker's flag.)"""
        if seed is not None:
            check_seed("seed", seed)
        batched.check_reset_options(options)
        super().reset(seed=seed)  # type: ignore[misc]  # gymnasium's Env/VectorEnv, next in the adapter's MRO
        if seed is not None:
            self._key = jax.random.PRNGKey(seed)
        elif self._key is None:
            self._key = jax.random.PRNGKey(int(self.np_random.integers(0, 2**31 - 1)))
        self._key, obs, self._state = self._reset_fn(self._key, self.params)
        self._ended = None
        return np.asarray(obs, dtype=np.float32), {}

    def _host_state(self, what: str) -> tuple[Any, Any] | None:
        """``(state, params)`` on the host for ``render``; None (with a warning) without a render mode."""
        if self.render_mode is None:
            gymnasium.logger.warn(f"{what}() called without a render_mode; pass render_mode='ansi' or 'rgb_array'")
            return None
        if self._state is None:
            raise RuntimeError(f"call reset() before {what}()")
        return jax.device_get((self._state, self.params))


class JaxToGymnasium(_KeyedReset, gymnasium.Env):
    """A jaxdc :class:`~jaxdc.core.env.Environment` as a :class:`gymnasium.Env`.

    Args:
      env: the functional environment.
      params: its ``EnvParams`` (default: ``env.default_params``), checked once here, values included
        (:func:`jaxdc.wrappers.batched.check_params`).
      render_mode: ``None``, ``"ansi"`` (text) or ``"rgb_array"`` (``uint8 [H, W, 3]``; environments that
        write ``scene``, as the DCP and DCG do).
      outcome_names: names for ``info["outcome"]`` indices (default: the
        env's ``outcomes``); the index stays in ``info["outcome_index"]``.
      observation_space: override of the default ``Box`` (the env's own
        ``observation_space(params)``; unbounded where the env does not bound
        its observations).
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 4}

    def __init__(self, env: Environment, params: Any = None, render_mode: str | None = None,
                 outcome_names: Sequence[str] | None = None, observation_space: spaces.Space | None = None) -> None:
        self.render_mode = _check_render_mode(render_mode, env)
        self.env = env
        self.params = batched.check_params(env, env.default_params if params is None else params)
        self.observation_space, self.action_space = batched.host_spaces(env, self.params, observation_space)
        self.outcome_names = _outcome_names(env, outcome_names)
        self._key = None
        self._state = None
        self._reset_fn = partial(batched.reset_one, env)
        self._step_fn = partial(batched.step_one, env)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One step (no auto-reset). After a step that returned ``terminated`` or ``truncated`` the episode is
        over: a further ``step`` without ``reset()`` raises ``RuntimeError`` (gymnasium's convention) instead
        of stepping a finished episode."""
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        if self._ended is not None:
            raise RuntimeError(f"the episode has ended ({self._ended}); call reset() before step()")
        action = _check_action(action, int(self.env.num_actions))
        out = self._step_fn(self._key, self._state, action, self.params)
        self._key, obs, self._state, reward, terminated, truncated, info = out
        obs, reward, terminated, truncated, info = jax.device_get((obs, reward, terminated, truncated, info))
        if bool(terminated) or bool(truncated):
            self._ended = "terminated" if bool(terminated) else "truncated"
        return (
            np.asarray(obs, dtype=np.float32),
            float(reward),
            bool(terminated),
            bool(truncated),
            self._info(info),
        )

    def _info(self, info: dict[str, Any]) -> dict[str, Any]:
        out = {}
        for k, v in info.items():
            v = np.asarray(v)
            out[k] = v.item() if v.shape == () else v
        if "outcome" in out and self.outcome_names is not None:
            out["outcome_index"] = int(out["outcome"])
            out["outcome"] = self.outcome_names[int(out["outcome"])]
        return out

    def render(self) -> Any:  # str (ansi) or uint8 [H, W, 3] (rgb_array)
        host = self._host_state("render")
        return None if host is None else _renderer(self.env, self.render_mode or "ansi")(*host)


class JaxVectorEnv(_KeyedReset, gymnasium.vector.VectorEnv):
    """``num_envs`` copies of a jaxdc environment behind one jitted ``vmap`` step.

    Same-step auto-reset (jaxdc's ``Environment.step``): see the module docs.
    ``info`` holds, per copy and each with its ``_key`` mask, ``final_obs``
    (an object array, the finished episode's last observation where
    ``terminated | truncated``, else ``None``), and the step infos of the
    underlying env (for the DCP: ``outcome`` names, ``episode_reward``,
    ``episode_energy``, ``episode_steps`` -- those of the finished episode on
    the step it ends).
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 4, "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(self, env: Environment, num_envs: int, params: Any = None, render_mode: str | None = None,
                 outcome_names: Sequence[str] | None = None, observation_space: spaces.Space | None = None) -> None:
        check_positive_int("num_envs", num_envs)
        self.render_mode = _check_render_mode(render_mode, env)
        self.env = env
        self.num_envs = int(num_envs)
        self.params = batched.check_params(env, env.default_params if params is None else params)
        batched.check_batch_fits(env, self.params, self.num_envs)
        self.single_observation_space, self.single_action_space = batched.host_spaces(env, self.params,
                                                                                      observation_space)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.outcome_names = _outcome_names(env, outcome_names)
        self._key = None
        self._state = None
        self._reset_fn = partial(batched.reset, env, self.num_envs)
        self._step_fn = partial(batched.step, env, self.num_envs)

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        a = np.asarray(actions)
        if a.shape != (self.num_envs,) or not np.issubdtype(a.dtype, np.integer) or not self.action_space.contains(
            a.astype(self.action_space.dtype)
        ):
            raise ValueError(
                f"actions must be {self.num_envs} ints in [0, {self.env.num_actions}), got {actions!r}"
            )
        out = self._step_fn(self._key, self._state, a.astype(np.int32), self.params)
        self._key, obs, self._state, reward, terminated, truncated, info = out
        obs, reward, terminated, truncated, info = jax.device_get((obs, reward, terminated, truncated, info))
        terminated = np.asarray(terminated, dtype=np.bool_)
        truncated = np.asarray(truncated, dtype=np.bool_)
        return (
            np.asarray(obs, dtype=np.float32),
            np.asarray(reward, dtype=np.float64),
            terminated,
            truncated,
            self._info(info, terminated | truncated),
        )

    def _info(self, info: dict[str, Any], done: np.ndarray) -> dict[str, Any]:
        info = dict(info)
        final = np.asarray(info.pop("final_observation"), dtype=np.float32)
        out: dict[str, Any] = {}
        for k, v in info.items():
            v = np.asarray(v)
            if k == "outcome" and self.outcome_names is not None:
                out["outcome_index"] = v.astype(np.int64)
                out["_outcome_index"] = np.ones(self.num_envs, np.bool_)
                v = np.array([self.outcome_names[int(i)] for i in v], dtype=object)
            out[k] = v
            out[f"_{k}"] = np.ones(self.num_envs, np.bool_)
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in np.flatnonzero(done):
            final_obs[i] = final[i]
        out["final_obs"] = final_obs
        out["_final_obs"] = done.copy()
        return out

    def render(self) -> tuple[Any, ...] | None:
        host = self._host_state("render")
        if host is None:
            return None
        state, params = host
        render = _renderer(self.env, self.render_mode or "ansi")
        return tuple(
            render(jax.tree_util.tree_map(lambda x, i=i: x[i], state), params) for i in range(self.num_envs)
        )


# -- entry points of "jaxdc/DCP-v0" --------------------------------------------------------


def _build_dcp(risk: Any, energy: Any, grid_size: int, total_reward: int, max_steps: int, start: str,
               dcp_kwargs: dict[str, Any]) -> tuple[Environment, Any]:
    from jaxdc.dcp.env import DCP

    env = DCP(grid_size=grid_size, total_reward=total_reward, start=start, **dcp_kwargs)
    return env, env.make_params(risk=risk, energy=energy, max_steps=max_steps)


def make_dcp(risk: Any = "high", energy: Any = (8.0, 16.0), grid_size: int = 8, total_reward: int = 30,
             max_steps: int = 1000, start: str = "random_free", render_mode: str | None = None,
             **dcp_kwargs: Any) -> JaxToGymnasium:
    """The DCP as a :class:`JaxToGymnasium` (entry point of ``"jaxdc/DCP-v0"``).

    ``dcp_kwargs`` go to :class:`~jaxdc.dcp.env.DCP` (``items_on_base``,
    ``energy_metric``, ``idle_terminates``); ``risk``/``energy``/``max_steps``
    to ``DCP.make_params``. Both validate (``ValueError``/``TypeError``).
    """
    _check_render_mode(render_mode)
    env, params = _build_dcp(risk, energy, grid_size, total_reward, max_steps, start, dcp_kwargs)
    return JaxToGymnasium(env, params, render_mode=render_mode)


def make_dcp_vector(num_envs: int = 1, risk: Any = "high", energy: Any = (8.0, 16.0), grid_size: int = 8,
                    total_reward: int = 30,
                    max_steps: int = 1000, start: str = "random_free", render_mode: str | None = None,
                    **dcp_kwargs: Any) -> JaxVectorEnv:
    """The DCP as a :class:`JaxVectorEnv` (vector entry point of ``"jaxdc/DCP-v0"``)."""
    _check_render_mode(render_mode)
    env, params = _build_dcp(risk, energy, grid_size, total_reward, max_steps, start, dcp_kwargs)
    return JaxVectorEnv(env, num_envs, params, render_mode=render_mode)


# -- entry points of "jaxdc/DCG-v0" --------------------------------------------------------


def _build_dcg(energy: float, max_steps: int, chase_tie: str, dcg_kwargs: dict[str, Any]) -> tuple[Environment, Any]:
    from jaxdc.dcg.env import DCG

    env = DCG(**dcg_kwargs)
    return env, env.make_params(energy=energy, max_steps=max_steps, chase_tie=chase_tie)


def make_dcg(energy: float = 15.0, max_steps: int = 100, chase_tie: str = "straight",
             render_mode: str | None = None, **dcg_kwargs: Any) -> JaxToGymnasium:
    """The DCG as a :class:`JaxToGymnasium` (entry point of ``"jaxdc/DCG-v0"``).

    ``dcg_kwargs`` go to :class:`~jaxdc.dcg.env.DCG` (``grid_size``,
    ``strategies``, ``history``, ``obs_history``, ...); ``energy``/``max_steps``/
    ``chase_tie`` to ``DCG.make_params``. Both validate. ``info`` carries
    ``opponent_action`` (``o_t``) and ``strategy`` (index into ``env.strategies``).
    """
    _check_render_mode(render_mode)
    env, params = _build_dcg(energy, max_steps, chase_tie, dcg_kwargs)
    return JaxToGymnasium(env, params, render_mode=render_mode)


def make_dcg_vector(num_envs: int = 1, energy: float = 15.0, max_steps: int = 100, chase_tie: str = "straight",
                    render_mode: str | None = None, **dcg_kwargs: Any) -> JaxVectorEnv:
    """The DCG as a :class:`JaxVectorEnv` (vector entry point of ``"jaxdc/DCG-v0"``)."""
    _check_render_mode(render_mode)
    env, params = _build_dcg(energy, max_steps, chase_tie, dcg_kwargs)
    return JaxVectorEnv(env, num_envs, params, render_mode=render_mode)
