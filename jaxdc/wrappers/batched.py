"""The compiled single and batched steps behind the adapters, and their host spaces.

:class:`jaxdc.wrappers.gymnasium.JaxToGymnasium`, :class:`jaxdc.wrappers.gymnasium.JaxVectorEnv` and
:class:`jaxdc.wrappers.sb3.JaxdcVecEnv` share these functions. Each is jitted with the
environment as a static argument (the :class:`~jaxdc.core.env.Environment` base
compares and hashes environments by their configuration) and the parameters as a
traced pytree, so one compiled function serves every adapter of one environment
configuration (and batch size), and reset/step never retrace after the first call.

Key scheme: each call splits the adapter's key, ``key, sub = split(key)``,
returns the new ``key`` first and uses ``sub`` (the batched functions split
``sub`` into ``num_envs`` keys).
"""

from __future__ import annotations

from functools import partial
from typing import Any

import jax
import numpy as np
from gymnasium import spaces

from jaxdc.core import memory
from jaxdc.core.env import Environment

__all__ = ["reset_one", "step_one", "reset", "step", "host_spaces", "RESET_OPTIONS", "check_reset_options",
           "check_params", "BATCH_COPIES", "check_batch_fits"]

#: The reset options the adapters take: none (the environment's parameters are set with ``params=...``).
RESET_OPTIONS: tuple[str, ...] = ()


def check_reset_options(options: Any, name: str = "options") -> None:
    """Refuse reset ``options`` (``None`` or a dict of :data:`RESET_OPTIONS` keys): a ``TypeError`` for a non-dict,
    a ``ValueError`` naming the unknown keys and the allowed ones, so a misspelt or unsupported option is never
    silently ignored."""
    if options is None:
        return
    if not isinstance(options, dict):
        raise TypeError(f"{name} must be a dict or None, got {type(options).__name__}")
    unknown = sorted(map(str, set(options) - set(RESET_OPTIONS)))
    if unknown:
        allowed = f"the allowed keys are {list(RESET_OPTIONS)}" if RESET_OPTIONS else "the jaxdc adapters take none"
        raise ValueError(f"reset options {unknown} are not known: {allowed} (set the environment's parameters with "
                         "params=...)")


@partial(jax.jit, static_argnums=0)
def reset_one(env: Environment, key: jax.Array, params: Any) -> tuple[jax.Array, jax.Array, Any]:
    """``(key, obs, state)``: one fresh episode."""
    key, sub = jax.random.split(key)
    obs, state = env.reset_env(sub, env.check_params(params))
    return key, obs, state


@partial(jax.jit, static_argnums=0)
def step_one(env: Environment, key: jax.Array, state: Any, action: jax.Array, params: Any) -> tuple:
    """``(key, obs, state, reward, terminated, truncated, info)``: one transition, without auto-reset."""
    key, sub = jax.random.split(key)
    return (key,) + tuple(env.step_env(sub, env.check_state(state), action, env.check_params(params)))


@partial(jax.jit, static_argnums=(0, 1))
def reset(env: Environment, num_envs: int, key: jax.Array, params: Any) -> tuple[jax.Array, jax.Array, Any]:
    """``(key, obs, state)`` of ``num_envs`` fresh episodes (leading axis ``num_envs``)."""
    key, sub = jax.random.split(key)
    obs, state = jax.vmap(env.reset_env, in_axes=(0, None))(jax.random.split(sub, num_envs), env.check_params(params))
    return key, obs, state


@partial(jax.jit, static_argnums=(0, 1))
def step(env: Environment, num_envs: int, key: jax.Array, state: Any, actions: jax.Array, params: Any) -> tuple:
    """``(key, obs, state, reward, terminated, truncated, info)`` of ``num_envs`` copies stepped at once, with
    the same-step auto-reset of :meth:`~jaxdc.core.env.Environment.step` (``info["final_observation"]``)."""
    key, sub = jax.random.split(key)
    out = jax.vmap(env.step, in_axes=(0, 0, 0, None))(jax.random.split(sub, num_envs), state, actions, params)
    return (key,) + tuple(out)


def check_params(env: Environment, params: Any) -> Any:
    """``params`` checked once, at an adapter's entry (outside jit): their kind and shapes
    (:meth:`~jaxdc.core.env.Environment.check_params`), then their values
    (:meth:`~jaxdc.core.env.Environment.check_param_values`: for the DCP and the DCG, risks finite in ``[0, 1]``
    with base risk 0, energies > 0 or ``inf``, ``max_steps`` >= 1, ...), so params edited with ``.replace(...)``
    (a NaN risk map, an infinite risk) are refused with a ``ValueError`` naming the field instead of playing
    silently."""
    return env.check_param_values(env.check_params(params))


#: A vector adapter holds about this many copies of a batch's observations and states: the device state and
#: observation, the host copies it hands out, and the batched observation space's bounds (two arrays of the
#: batch's observation shape).
BATCH_COPIES = 4


def check_batch_fits(env: Environment, params: Any, num_envs: int) -> None:
    """``MemoryError`` naming ``num_envs`` when :data:`BATCH_COPIES` copies of ``num_envs`` observations and states
    of ``env`` would not fit in memory (:func:`jaxdc.core.memory.check_fits`), before any of them is allocated."""
    obs, state = jax.eval_shape(env.reset, jax.random.PRNGKey(0), params)
    per_env = memory.tree_bytes(obs) + memory.tree_bytes(state)
    memory.check_fits(BATCH_COPIES * int(num_envs) * per_env, f"{num_envs} copies of {env.name}", "num_envs")


def host_spaces(env: Environment, params: Any,
                observation_space: spaces.Space | None = None) -> tuple[spaces.Space, spaces.Discrete]:
    """gymnasium ``(observation_space, action_space)`` of one copy, from the environment's own (finite)
    ``observation_space(params)``; an environment that does not bound its observations (``observation_bounds``
    not written) gets an unbounded Box. ``observation_space`` overrides the first."""
    if observation_space is None:
        shape = tuple(int(s) for s in env.observation_shape(params))
        try:
            box = env.observation_space(params)
            low, high = box.low, box.high
        except NotImplementedError:
            low, high = np.full(shape, -np.inf, np.float32), np.full(shape, np.inf, np.float32)
        observation_space = spaces.Box(low=low, high=high, shape=shape, dtype=np.float32)
    return observation_space, spaces.Discrete(int(env.num_actions))
