"""A minimal hand-batched JAX DCP: the yardstick row ``jax_handbatched`` of ``benchmarks/env_throughput.py``.

The rules of :class:`jaxdc.dcp.env.DCP` with its defaults (start ``random_free``, items on the base, energy
metric ``not_stay_in_base``, no idle termination), written the way a skilled user who needs only this one
setting would write them: the batch is the leading axis of flat arrays (a cell index instead of a position,
no episode totals), one key per step for the whole batch, and the observation ``[B, N, N, 2]`` built on
every step, as the library's step does. Fresh initial states are drawn only for the environments that
finished, a chunk at a time (the chunk of :func:`jaxdc.core.env.reset_chunk_size`), as the NumPy batch and
the library do. Until issue 30 this yardstick drew a fresh state for every environment on every step: 2.84M
env-steps/s at B = 4,096 then, 5.69M-5.89M now (``python benchmarks/env_throughput.py --batch-sizes 4096
--no-table43``, 2026-12-07 and 12-08). Its random streams differ from the library's, so only the distributions
agree; it is a speed yardstick, not part of the library.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxdc.core import grid
from jaxdc.core.env import reset_chunk_size
from jaxdc.core.sampling import running_count, uniform_index


def make_rollout(risk, energy, max_steps: int, total_reward: int, batch: int, steps: int):
    """A jitted ``rollout(key) -> (obs, total reward)`` of ``steps`` random-policy steps of ``batch`` DCPs."""
    n = risk.shape[0]
    cells = n * n
    risk_flat = jnp.asarray(risk, jnp.float32).reshape(-1)
    init_e, max_e = (jnp.float32(e) for e in energy)
    deltas = jnp.asarray(grid.DELTAS_NP)
    ids = jnp.arange(cells, dtype=jnp.int32)
    chunk = min(reset_chunk_size(batch), batch)
    chunks = -(-batch // chunk)

    def reset(key, b):
        k_drop, k_start = jax.random.split(key)
        where = uniform_index(k_drop, (b, total_reward), cells)
        items = jnp.zeros((b, cells), jnp.float32).at[jnp.arange(b)[:, None], where].add(1.0)
        free = items == 0
        free = jnp.where(free.any(-1, keepdims=True), free, True)
        count = jax.vmap(running_count)(free)
        k = uniform_index(k_start, (b,), count[:, -1])
        flat = jnp.sum(count <= k[:, None], axis=-1, dtype=jnp.int32)
        return items, flat, jnp.full(b, init_e), jnp.zeros(b, jnp.int32)

    def observe(items, flat, energy):
        agent = jnp.where(ids[None, :] == flat[:, None], energy[:, None], 0.0)
        return jnp.stack([items, agent], axis=-1).reshape(-1, n, n, 2)

    def reset_done(key, done, state):
        where = jnp.nonzero(done, size=chunks * chunk, fill_value=batch)[0]

        def fill(i, cur):
            rows = jax.lax.dynamic_slice_in_dim(where, i * chunk, chunk)
            fresh = reset(jax.random.fold_in(key, i), chunk)
            return tuple(a.at[rows].set(f, mode="drop") for a, f in zip(cur, fresh))

        finished = jnp.sum(done, dtype=jnp.int32)
        return jax.lax.fori_loop(0, (finished + chunk - 1) // chunk, fill, state)

    def step(key, state, action):
        items, flat, energy, time = state
        k_risk, k_reset = jax.random.split(key)
        d = deltas[action]
        r = jnp.clip(flat // n + d[:, 0], 0, n - 1)
        c = jnp.clip(flat % n + d[:, 1], 0, n - 1)
        flat = r * n + c
        rows = jnp.arange(batch)
        reward = items[rows, flat]
        items = items.at[rows, flat].set(0.0)
        hit = jax.random.uniform(k_risk, (batch,)) < risk_flat[flat]
        in_base = flat == 0
        energy = jnp.where(in_base, max_e, jnp.maximum(energy - 1.0, 0.0))
        time = time + 1
        done = hit | (~in_base & (energy <= 0)) | jnp.all(items <= 0, axis=-1) | (time >= max_steps)
        state = reset_done(k_reset, done, (items, flat, energy, time))
        return state, observe(*state[:3]), reward

    @jax.jit
    def rollout(key):
        k_reset, k_loop = jax.random.split(key)
        state = reset(k_reset, batch)

        def body(carry, k):
            state, obs, total = carry
            k_act, k_step = jax.random.split(k)
            action = uniform_index(k_act, (batch,), grid.NUM_ACTIONS)
            state, obs, reward = step(k_step, state, action)
            return (state, obs, total + reward.sum()), None

        obs = observe(*state[:3])
        (state, obs, total), _ = jax.lax.scan(body, (state, obs, jnp.float32(0.0)), jax.random.split(k_loop, steps))
        return obs, total

    return rollout
