"""Shared DCG test helpers: batches of reset games, playing a policy on them, and the best of every action
sequence (brute force in the env itself)."""

import itertools

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core import grid


def simulate(env, params, policy, states, steps, seed=0):
    """Total reward of each game in the batch ``states`` under ``policy`` for ``steps`` steps (no auto-reset)."""

    def one(state, key):
        def body(carry, t):
            s, done, total = carry
            k_act, k_step = jax.random.split(jax.random.fold_in(key, t))
            _, s2, r, term, trunc, _ = env.step_env(k_step, s, policy(k_act, None, s), params)
            return (s2, done | term | trunc, total + jnp.where(done, 0.0, r)), None

        (_, _, total), _ = jax.lax.scan(body, (state, jnp.bool_(False), jnp.float32(0.0)), jnp.arange(steps))
        return total

    keys = jax.random.split(jax.random.PRNGKey(seed), states.time.shape[0])
    return np.asarray(jax.jit(jax.vmap(one))(states, keys))


def resets(env, params, count, seed=0):
    keys = jax.random.split(jax.random.PRNGKey(seed), count)
    _, s = jax.jit(jax.vmap(env.reset_env, in_axes=(0, None)))(keys, params)
    return s


def play_sequence(env, params, state, seq):
    """Total reward of the action sequence ``seq`` played from ``state`` in the env (nothing after the end)."""

    def body(carry, a):
        s, done, total = carry
        _, s2, r, term, trunc, _ = env.step_env(jax.random.PRNGKey(0), s, a, params)
        return (s2, done | term | trunc, total + jnp.where(done, 0.0, r)), None

    (_, _, total), _ = jax.lax.scan(body, (state, jnp.bool_(False), jnp.float32(0.0)), seq)
    return total


def best_sequence(env, params, states, horizon):
    """The most reward any sequence of ``horizon`` actions earns from each state, in the env itself. The
    opponents here are deterministic, so open-loop sequences are all the policies there are."""
    seqs = jnp.asarray(list(itertools.product(range(grid.NUM_ACTIONS), repeat=horizon)), jnp.int32)

    def play(state, seq):
        return play_sequence(env, params, state, seq)

    best = jax.vmap(lambda state: jnp.max(jax.vmap(play, in_axes=(None, 0))(state, seqs)))
    return np.asarray(jax.jit(best)(states))
