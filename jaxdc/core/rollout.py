"""Batched evaluation episodes for any :class:`jaxdc.core.env.Environment`.

:func:`run_episodes` plays ``num_episodes`` independent episodes at once,
each from its own key, until every one has terminated or been truncated.
Finished episodes are frozen (no auto-reset), so the returned final states
hold each episode's own metrics. It runs in one ``lax.while_loop`` that
stops as soon as the last episode ends.

The policy is ``policy(key, obs, state) -> action`` for one environment; it
is vmapped here. It may close over network parameters, path tables and so on.
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp

from jaxdc.core.env import tree_select


def run_episodes(env, params, policy: Callable, key, num_episodes: int):
    """Play ``num_episodes`` episodes with ``policy``; return the final (frozen) states, batched.

    Deterministic in ``key``. ``params`` is shared by all episodes; to mix
    parameters, vmap this function over them.
    """
    k_reset, k_loop = jax.random.split(key)
    obs, state = jax.vmap(env.reset_env, in_axes=(0, None))(jax.random.split(k_reset, num_episodes), params)
    done = jnp.zeros(num_episodes, bool)

    def one(key, obs, state, done):
        k_act, k_step = jax.random.split(key)
        action = policy(k_act, obs, state)
        obs2, state2, _, term, trunc, _ = env.step_env(k_step, state, action, params)
        state2 = tree_select(done, state, state2)
        obs2 = jnp.where(done, obs, obs2)
        return obs2, state2, done | term | trunc

    def body(carry):
        key, obs, state, done = carry
        key, sub = jax.random.split(key)
        obs, state, done = jax.vmap(one)(jax.random.split(sub, num_episodes), obs, state, done)
        return key, obs, state, done

    carry = jax.lax.while_loop(lambda c: ~jnp.all(c[3]), body, (k_loop, obs, state, done))
    return carry[2]
