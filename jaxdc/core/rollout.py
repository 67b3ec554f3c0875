"""Batched evaluation episodes for any :class:`jaxdc.core.env.Environment`.

:func:`run_episodes` plays ``num_episodes`` independent episodes and returns
the final state of each. It runs a fixed number of *lanes* in one
``lax.while_loop``: when an episode ends, its lane starts the next episode
that has not been played yet, so a few long episodes do not keep the whole
batch busy. Every episode draws its randomness from its own key (its reset
from ``split(key, num_episodes)[i]``, its step ``t`` from ``fold_in`` of that
key and ``t``), so the results do not depend on the number of lanes or on
the order in which episodes finish.

The policy is ``policy(key, obs, state) -> action`` for one environment; it
is vmapped here and may close over network parameters, path tables and so on.

An evaluation whose games never end (a huge step cap) can run for hours inside
one ``while_loop``. A loop *traced* inside :func:`reporting` calls the host
(``jax.debug.callback``) every :data:`HEARTBEAT_EVERY` loop iterations with its
progress, and the reporter of the innermost block gets it. Loops traced outside
any block carry no call: JAX's persistent compile cache does not keep programs
with host callbacks, so the progress call is compiled in only where it is
wanted (the command lines ask for it when the step cap allows long games,
:func:`jaxdc.cli.runner.progress`). The callback reads values and returns
nothing, so the results are the same with or without it.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any, Callable

import jax
import jax.numpy as jnp

from jaxdc.core import memory
from jaxdc.core.env import Environment, tree_select

#: Default number of lanes (episodes stepped at once).
DEFAULT_LANES = 2048
#: Loop iterations (lane steps) between two progress calls to the host.
HEARTBEAT_EVERY = 4096

#: ``report(finished, total, iterations)`` of the innermost :func:`reporting`, or None.
_reporters: list[Callable[[int, int, int], None]] = []


@contextlib.contextmanager
def reporting(report: Callable[[int, int, int], None]) -> Iterator[None]:
    """Every :func:`run_episodes` *traced* within this block calls ``report(finished, total, iterations)`` from
    the host every :data:`HEARTBEAT_EVERY` loop iterations: ``finished`` of ``total`` episodes have ended after
    ``iterations`` steps of the lanes. A jitted function traced before the block (and cached) stays silent.
    ``report`` should return quickly (it runs while the loop waits)."""
    _reporters.append(report)
    try:
        yield
    finally:
        _reporters.remove(report)


def _heartbeat(finished, total, iterations) -> None:
    """The host side of the loop's progress call: pass it to the innermost reporter, if any."""
    if _reporters:
        _reporters[-1](int(finished), int(total), int(iterations))


def _take(tree, index):
    return jax.tree_util.tree_map(lambda x: x[index], tree)


def initial_states(env: Environment, params: Any, key: jax.Array, num_episodes: int) -> tuple[Any, Any, jax.Array]:
    """``(observations, states, step keys)`` at the start of the ``num_episodes`` episodes that
    :func:`run_episodes` plays with ``key``: episode ``i`` resets from its own key, so an exact yardstick
    computed on these states (:mod:`jaxdc.dcp.exact.unlimited`) is paired with the evaluation's episodes."""
    ep_keys = jax.random.split(key, int(num_episodes))
    reset_keys, run_keys = jnp.split(jax.vmap(lambda k: jax.random.split(k, 2))(ep_keys), 2, axis=1)
    obs0, state0 = jax.vmap(env.reset_env, in_axes=(0, None))(reset_keys[:, 0], params)
    return obs0, state0, run_keys[:, 0]


def run_episodes(env: Environment, params: Any, policy: Callable, key: jax.Array, num_episodes: int,
                 lanes: int | None = None) -> Any:
    """Play ``num_episodes`` episodes with ``policy``; return their final states, batched ``[num_episodes]``.

    Episodes end when terminated or truncated (``params``' step cap); they are
    not auto-reset. ``params`` is shared by all episodes; to mix parameters,
    vmap this function over them. ``lanes`` (default ``min(num_episodes,
    2048)``) trades memory for speed and never changes the results.
    """
    env.check_params(params)  # another environment's (another grid size): refused before tracing
    n = int(num_episodes)
    lanes = min(n, int(lanes or DEFAULT_LANES))
    obs_shape, state_shape = jax.eval_shape(env.reset_env, jax.random.PRNGKey(0), params)
    # every episode's initial state, observation and final state are held at once, plus its two keys
    per_episode = memory.tree_bytes(obs_shape) + 2 * memory.tree_bytes(state_shape) + 32
    memory.check_fits(n * per_episode, f"{n} evaluation episodes", "the number of episodes")
    obs0, state0, run_keys = initial_states(env, params, key, n)

    def one(key, obs, state):
        k_act, k_step = jax.random.split(key)
        action = policy(k_act, obs, state)
        obs2, state2, _, term, trunc, _ = env.step_env(k_step, state, action, params)
        return obs2, state2, term | trunc

    beat = bool(_reporters)  # at trace time: compile the progress call in only where someone listens

    def body(carry):
        obs, state, episode, active, next_episode, finals, finished_count, iteration = carry
        if beat:
            jax.lax.cond(iteration % HEARTBEAT_EVERY == HEARTBEAT_EVERY - 1,
                         lambda: jax.debug.callback(_heartbeat, finished_count, n, iteration + 1), lambda: None)
        step_keys = jax.vmap(jax.random.fold_in)(run_keys[episode], state.time)
        obs2, state2, done = jax.vmap(one)(step_keys, obs, state)
        ended = active & done
        # record the episodes that ended; indices past the end are dropped
        slot = jnp.where(ended, episode, n)
        finals = jax.tree_util.tree_map(lambda f, s: f.at[slot].set(s, mode="drop"), finals, state2)
        # refill their lanes with the next unplayed episodes
        new_episode = next_episode + jnp.cumsum(ended) - 1
        refill = ended & (new_episode < n)
        episode = jnp.where(refill, new_episode, episode)
        fresh = jnp.minimum(new_episode, n - 1)
        state2 = tree_select(refill, _take(state0, fresh), state2)
        obs2 = tree_select(refill, obs0[fresh], obs2)
        active = jnp.where(ended, refill, active)
        count = jnp.sum(ended)
        return obs2, state2, episode, active, next_episode + count, finals, finished_count + count, iteration + 1

    carry = (
        obs0[:lanes],
        _take(state0, jnp.arange(lanes)),
        jnp.arange(lanes),
        jnp.ones(lanes, bool),
        jnp.int32(lanes),
        state0,
        jnp.int32(0),
        jnp.int32(0),
    )
    carry = jax.lax.while_loop(lambda c: c[6] < n, body, carry)
    return carry[5]
