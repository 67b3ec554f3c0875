"""The functional environment base shared by the DCP and the DCG (gymnax style).

A subclass writes three pure functions of arrays:

* ``reset_env(key, params) -> (obs, state)``
* ``step_env(key, state, action, params) -> (obs, state, reward, terminated, truncated, info)``
* ``observe(state, params) -> obs``

and the base class adds auto-reset: :meth:`Environment.step` resets an
environment whose episode ended, returns the *first* observation of the new
episode, and keeps the last observation of the finished one in
``info["final_observation"]``. ``terminated`` (a terminal state of the MDP)
and ``truncated`` (the step cap) are kept apart, as gymnasium does.

Static configuration (grid size, the thesis' ambiguity choices) belongs to
the constructor and is validated there; numeric settings that may differ
within one batch (risk maps, energies, the step cap) are ``EnvParams``
leaves, so ``jax.vmap`` can map over them.
"""

from __future__ import annotations

from typing import Any, Generic, TypeVar

import jax
import jax.numpy as jnp

from jaxdc.core import grid, spaces

S = TypeVar("S")
P = TypeVar("P")


class Environment(Generic[S, P]):
    """Base of the jaxdc environments: pure, jittable and vmappable."""

    def make_params(self, **kwargs) -> P:
        """Validated parameters (written by subclasses)."""
        raise NotImplementedError

    @property
    def default_params(self) -> P:
        return self.make_params()

    def _config(self) -> tuple:
        """The static configuration (constructor arguments) as a hashable tuple."""
        raise NotImplementedError

    # An environment is a static argument of jitted functions: equal configurations
    # compare and hash equal, so they share compiled code.
    def __eq__(self, other) -> bool:
        return type(other) is type(self) and other._config() == self._config()

    def __hash__(self) -> int:
        return hash((type(self).__name__,) + self._config())

    @property
    def num_actions(self) -> int:
        """The 9 grid actions of :data:`jaxdc.core.grid.ACTIONS` (both grid problems use them)."""
        return grid.NUM_ACTIONS

    def observation_shape(self, params: P) -> tuple[int, ...]:
        raise NotImplementedError

    @property
    def name(self) -> str:
        """The environment's name (gymnax's ``env.name``)."""
        return type(self).__name__

    def action_space(self, params: P | None = None) -> spaces.Discrete:
        """The 9 grid actions (gymnax's ``action_space(params)``)."""
        return spaces.Discrete(self.num_actions)

    def observation_space(self, params: P) -> spaces.Box:
        """The observations under ``params``, with finite bounds (gymnax's ``observation_space(params)``)."""
        low, high = self.observation_bounds(params)
        return spaces.Box(low, high, self.observation_shape(params), jnp.float32)

    def observation_bounds(self, params: P):
        """``(low, high)`` arrays (or numbers) bounding every observation (written by subclasses)."""
        raise NotImplementedError

    # -- to be written by subclasses -------------------------------------------------
    def reset_env(self, key, params: P):
        raise NotImplementedError

    def step_env(self, key, state: S, action, params: P):
        raise NotImplementedError

    def observe(self, state: S, params: P):
        raise NotImplementedError

    # -- public API ---------------------------------------------------------------------
    def reset(self, key, params: P | None = None):
        """Start an episode: ``(obs, state)``."""
        if params is None:
            params = self.default_params
        return self.reset_env(key, params)

    def step(self, key, state: S, action, params: P | None = None):
        """One transition with auto-reset.

        Returns ``(obs, state, reward, terminated, truncated, info)``. When the
        episode ends, ``obs``/``state`` are those of a fresh episode and
        ``info["final_observation"]`` holds the last observation of the old one
        (it equals ``obs`` otherwise).
        """
        if params is None:
            params = self.default_params
        key_step, key_reset = jax.random.split(key)
        obs_st, state_st, reward, terminated, truncated, info = self.step_env(
            key_step, state, action, params
        )
        obs_re, state_re = self.reset_env(key_reset, params)
        done = jnp.logical_or(terminated, truncated)
        state = tree_select(done, state_re, state_st)
        obs = jnp.where(done, obs_re, obs_st)
        info = dict(info)
        info["final_observation"] = obs_st
        return obs, state, reward, terminated, truncated, info


def step_batch(env: "Environment", key, state, action, params, reset_slots: int | None = None):
    """``B`` environments sharing ``params`` stepped at once, with auto-reset.

    With ``reset_slots=None`` this is ``vmap(env.step)`` over ``split(key, B)``.
    With ``reset_slots=K`` only ``K`` fresh initial states are drawn per step
    and handed to the environments that finished, in batch order; a step on
    which more than ``K`` finish falls back to ``B`` fresh states (a
    ``lax.cond``, so the fallback costs only when taken). Every new episode
    still starts from an independent initial state; the random streams differ
    from the ``None`` path, so the two give different (equally distributed)
    trajectories. Resets dominate the cost of a step when episodes are short,
    so a small ``K`` (a few times the expected number of finished episodes
    per step) makes large batches much faster.
    """
    b = action.shape[0]
    k_step, k_reset = jax.random.split(key)
    if reset_slots is None:
        return jax.vmap(env.step, in_axes=(0, 0, 0, None))(jax.random.split(key, b), state, action, params)
    obs_st, state_st, reward, terminated, truncated, info = jax.vmap(env.step_env, in_axes=(0, 0, 0, None))(
        jax.random.split(k_step, b), state, action, params
    )
    done = terminated | truncated
    k = min(int(reset_slots), b)

    def few(_):
        fresh = jax.vmap(env.reset_env, in_axes=(0, None))(jax.random.split(k_reset, k), params)
        slot = jnp.clip(jnp.cumsum(done) - 1, 0, k - 1)
        return jax.tree_util.tree_map(lambda x: x[slot], fresh)

    def all_(_):
        return jax.vmap(env.reset_env, in_axes=(0, None))(jax.random.split(k_reset, b), params)

    obs_re, state_re = jax.lax.cond(jnp.sum(done) <= k, few, all_, None)
    info = dict(info)
    info["final_observation"] = obs_st
    return (tree_select(done, obs_re, obs_st), tree_select(done, state_re, state_st), reward,
            terminated, truncated, info)


def tree_select(pred, on_true: Any, on_false: Any):
    """``jnp.where(pred, a, b)`` leaf by leaf over two pytrees of the same structure.

    ``pred`` may be batched (shape ``[B]``) over leaves of shape ``[B, ...]``.
    """

    def select(a, b):
        p = jnp.reshape(pred, jnp.shape(pred) + (1,) * (jnp.ndim(a) - jnp.ndim(pred)))
        return jnp.where(p, a, b)

    return jax.tree_util.tree_map(select, on_true, on_false)
