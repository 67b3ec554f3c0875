"""A minimal hand-batched JAX DCP: the yardstick row ``jax_handbatched`` of ``benchmarks/env_throughput.py``.

The rules of :class:`jaxdc.dcp.env.DCP` with its defaults (start ``random_free``, items on the base, energy
metric ``not_stay_in_base``, no idle termination), written the way a user who needs only this one setting
would write them: the batch is the leading axis of every array, one key per step for the whole batch,
one-hot masks instead of per-environment gathers and scatters, and every environment draws a fresh
initial state on every step, which the finished ones take. Its random streams differ from the library's
(``jaxdc.dcp.env`` splits one key per environment), so only the distributions agree; it is a speed
yardstick, not part of the library.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxdc.core import grid
from jaxdc.core.sampling import running_count, uniform_index


def make_rollout(risk, energy, max_steps: int, total_reward: int, batch: int, steps: int):
    """A jitted ``rollout(key) -> (obs, total reward)`` of ``steps`` random-policy steps of ``batch`` DCPs."""
    n = risk.shape[0]
    cells = n * n
    risk_flat = jnp.asarray(risk, jnp.float32).reshape(-1)
    init_e, max_e = (jnp.float32(e) for e in energy)
    deltas = jnp.asarray(grid.DELTAS_NP)
    ids = jnp.arange(cells, dtype=jnp.int32)

    def reset(key):
        k_drop, k_start = jax.random.split(key)
        where = uniform_index(k_drop, (batch, total_reward), cells)
        items = jnp.zeros((batch, cells), jnp.float32).at[jnp.arange(batch)[:, None], where].add(1.0)
        free = items == 0
        free = jnp.where(free.any(-1, keepdims=True), free, True)
        count = jax.vmap(running_count)(free)
        k = uniform_index(k_start, (batch,), count[:, -1])
        flat = jnp.sum(count <= k[:, None], axis=-1, dtype=jnp.int32)
        return items, flat, jnp.full(batch, init_e), jnp.zeros(batch, jnp.int32)

    def observe(items, flat, energy):
        agent = jnp.where(ids[None, :] == flat[:, None], energy[:, None], 0.0)
        return jnp.stack([items, agent], axis=-1).reshape(batch, n, n, 2)

    def step(key, state, action):
        items, flat, energy, time = state
        k_risk, k_reset = jax.random.split(key)
        d = deltas[action]
        r = jnp.clip(flat // n + d[:, 0], 0, n - 1)
        c = jnp.clip(flat % n + d[:, 1], 0, n - 1)
        flat = r * n + c
        here = ids[None, :] == flat[:, None]
        reward = jnp.sum(jnp.where(here, items, 0.0), axis=-1)
        items = jnp.where(here, 0.0, items)
        hit = jax.random.uniform(k_risk, (batch,)) < risk_flat[flat]
        in_base = flat == 0
        energy = jnp.where(in_base, max_e, jnp.maximum(energy - 1.0, 0.0))
        time = time + 1
        done = hit | (~in_base & (energy <= 0)) | jnp.all(items <= 0, axis=-1) | (time >= max_steps)
        fresh = reset(k_reset)
        state = tuple(jnp.where(done.reshape((batch,) + (1,) * (a.ndim - 1)), f, a)
                      for f, a in zip(fresh, (items, flat, energy, time)))
        return state, reward

    @jax.jit
    def rollout(key):
        k_reset, k_loop = jax.random.split(key)
        state = reset(k_reset)

        def body(carry, k):
            state, total = carry
            k_act, k_step = jax.random.split(k)
            action = uniform_index(k_act, (batch,), grid.NUM_ACTIONS)
            state, reward = step(k_step, state, action)
            return (state, total + reward.sum()), None

        (state, total), _ = jax.lax.scan(body, (state, jnp.float32(0.0)), jax.random.split(k_loop, steps))
        return observe(*state[:3]), total

    return rollout
