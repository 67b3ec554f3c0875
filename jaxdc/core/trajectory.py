"""One episode as a list of states, for drawing gameplay strips and animations (thesis Figs. 5.13-5.15).

:func:`jaxdc.core.rollout.run_episodes` keeps only the final state of each
episode; the viewer needs every state of one game. :func:`play_episode`
plays one unbatched episode of any :class:`jaxdc.core.env.Environment` with a
``policy(key, obs, state) -> action`` in one jitted ``lax.scan`` and returns
the states from the initial one up to the last (terminal or truncated) one.
"""

from __future__ import annotations

from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core import memory
from jaxdc.core.env import Environment
from jaxdc.core.validate import check_positive_int


def play_episode(env: Environment, params: Any, policy: Callable, key: jax.Array, max_steps: int) -> list:
    """States ``s_0 .. s_T`` of one episode (unbatched pytrees on the host), ``T <= max_steps``.

    The reset uses ``split(key)[0]``; step ``t`` draws its action and its
    transition from ``fold_in(split(key)[1], t)``, so the same key gives the
    same game, and two policies with the same key start from the same state
    (as the thesis' gameplay figures do). The episode stops at the first
    terminated or truncated step, or after ``max_steps`` steps.
    """
    max_steps = check_positive_int("max_steps", max_steps)
    env.check_params(params)  # another environment's (another grid size): refused before tracing
    _, state_shape = jax.eval_shape(env.reset_env, jax.random.PRNGKey(0), params)
    memory.check_fits(max_steps * memory.tree_bytes(state_shape), f"an episode of up to {max_steps} stored states",
                      "max_steps")

    @jax.jit
    def run(key):
        k_reset, k_run = jax.random.split(key)
        obs, state = env.reset_env(k_reset, params)

        def step(carry, t):
            obs, state, done = carry
            k_act, k_step = jax.random.split(jax.random.fold_in(k_run, t))
            action = policy(k_act, obs, state)
            obs2, state2, _, term, trunc, _ = env.step_env(k_step, state, action, params)
            return (obs2, state2, done | term | trunc), (state2, done | term | trunc)

        _, (states, done) = jax.lax.scan(step, (obs, state, jnp.bool_(False)), jnp.arange(max_steps))
        return state, states, done

    first, states, done = jax.device_get(run(key))
    done = np.asarray(done)
    length = int(np.argmax(done)) + 1 if done.any() else max_steps
    return [first] + [jax.tree_util.tree_map(lambda x, i=i: x[i], states) for i in range(length)]
