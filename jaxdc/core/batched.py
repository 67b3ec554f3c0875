"""A batch of environments stepped with batch-level random numbers (beyond the thesis; issue 30).

:meth:`jaxdc.core.env.Environment.step` takes one key per environment, as gymnax does: a batch of ``B``
environments under ``vmap`` splits ``B`` keys, and every environment splits its own key again into a step key
and a reset key before it draws its own numbers. :func:`step_batched` draws them for the whole batch instead:

* one key per batch step, split once into a step key and a reset key;
* the step's numbers of all ``B`` environments in one call (:meth:`Environment.step_noise` with ``batch=B``:
  the DCP's ``B`` risk uniforms; an environment that does not write the hook gets ``split(key, B)`` keys);
* fresh initial states only for the environments that finished, ``reset_chunk`` at a time
  (:func:`jaxdc.core.env.reset_finished`), each pass's keys split from the reset key.

Every episode has exactly the distribution it has under :meth:`Environment.step`: the same rules, applied to
numbers of the same distributions, independent across environments and steps. The random streams differ,
so the trajectories of one seed differ from ``vmap(env.step)``'s (tests/core/test_batched.py compares the two
distributions, episode by episode statistics, with two-sample tests).
"""

from __future__ import annotations

from typing import Any

import jax

from jaxdc.core.env import Environment, Transition, reset_finished
from jaxdc.core.validate import check_positive_int


def step_batched(env: Environment, key: jax.Array, state: Any, action: jax.Array, params: Any) -> Transition:
    """``B`` environments sharing ``params`` stepped at once with auto-reset, from one key.

    ``state`` and ``action`` have a leading batch axis ``B``; returns ``(obs, state, reward, terminated,
    truncated, info)`` batched the same way, as ``vmap(env.step)`` does, with ``info["final_observation"]``
    the last observation of each step's episode. Parameters, states or actions of another environment are
    refused with a ``ValueError`` when the step is traced (:meth:`Environment.check_params`).
    """
    env.check_params(params)
    env.check_state(state)
    env.check_action(action, batch_dims=1)
    b = action.shape[0]
    if b < 1:
        raise ValueError(f"action must hold one action per environment of a batch of at least 1, got shape "
                         f"{tuple(action.shape)}")
    k_step, k_reset = jax.random.split(key)
    step_noise, step_with_noise = noise_hooks(env)
    noise = step_noise(k_step, b, params)
    obs_st, state_st, reward, terminated, truncated, info = jax.vmap(
        step_with_noise, in_axes=(0, 0, 0, None))(noise, state, action, params)
    done = terminated | truncated
    obs, state = reset_finished(
        env, done, lambda i, ids: jax.random.split(jax.random.fold_in(k_reset, i), ids.shape[0]), params,
        (obs_st, state_st))
    info = dict(info)
    info["final_observation"] = obs_st
    return obs, state, reward, terminated, truncated, info


def noise_hooks(env: Environment) -> tuple[Any, Any]:
    """``(step_noise, step_with_noise)`` of ``env``, or the base class's (keys handed to ``step_env``) where a
    subclass overrides ``step_env`` below the class that wrote the hooks: those hooks would skip the override."""
    def owner(name: str) -> type:
        return next(c for c in type(env).__mro__ if name in vars(c))

    step_cls, hooks_cls = owner("step_env"), owner("step_with_noise")
    if step_cls is not hooks_cls and issubclass(step_cls, hooks_cls):
        return (Environment.step_noise.__get__(env), Environment.step_with_noise.__get__(env))
    return env.step_noise, env.step_with_noise


def reset_batched(env: Environment, key: jax.Array, batch: int, params: Any) -> tuple[jax.Array, Any]:
    """``batch`` initial states ``(obs, state)`` from one key (``vmap(env.reset)`` over ``split(key, batch)``);
    ``batch`` must be an integer >= 1."""
    batch = check_positive_int("batch", batch)
    return jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(key, batch), params)


__all__ = ["noise_hooks", "reset_batched", "step_batched"]
