"""Pinned trajectories: the same keys give bit-identical states, rewards and flags as the code of 2026-12-02.

The public step (auto-reset) and ``step_batch`` with ``reset_slots`` are run for many steps on fixed keys and
every state, reward and flag is hashed. A speed-up of the environments must keep these digests, so that no
published number moves (docs/results.md, "Speed (DCP)"); a change that alters the random streams on purpose
must regenerate the tables it touches and update the digests in the same commit.
"""

from __future__ import annotations

import hashlib

import jax
import numpy as np
import pytest

from jaxdc.core.env import step_batch
from jaxdc.dcg.env import DCG
from jaxdc.dcp.env import DCP

B, T = 64, 300


def _digest(env, params, reset_slots=None) -> str:
    @jax.jit
    def run(key):
        k_reset, k_loop = jax.random.split(key)
        _, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(k_reset, B), params)

        def body(state, k):
            k_act, k_step = jax.random.split(k)
            action = jax.random.randint(k_act, (B,), 0, env.num_actions)
            obs, state, reward, terminated, truncated, info = step_batch(env, k_step, state, action, params,
                                                                         reset_slots)
            return state, (state, obs, reward, terminated, truncated, info["final_observation"])

        return jax.lax.scan(body, state, jax.random.split(k_loop, T))[1]

    h = hashlib.sha256()
    for leaf in jax.tree_util.tree_leaves(jax.device_get(run(jax.random.PRNGKey(2026)))):
        a = np.ascontiguousarray(leaf)
        h.update(str(a.dtype).encode() + str(a.shape).encode() + a.tobytes())
    return h.hexdigest()[:16]


def _dcp(**kw):
    env = DCP(grid_size=8, total_reward=30, **kw)
    return env, env.make_params("high", (8.0, 16.0), max_steps=200)


def _dcg(**kw):
    env = DCG(**kw)
    return env, env.make_params(energy=15.0, max_steps=100)


CASES = {
    "dcp": (lambda: _dcp(), None, "a35eaeb6c7a478bb"),
    "dcp_slots": (lambda: _dcp(), 16, "105abfd7db81a8cd"),
    "dcp_random_start_row_major": (lambda: _dcp(start="random", item_order="row_major"), None, "18a138187f46e1cd"),
    "dcp_base_mix_idle": (lambda: _dcp(start="base", min_total_reward=1, idle_terminates=True), None,
                          "0b6d30bb328f97ca"),
    "dcg": (lambda: _dcg(), None, "22d9f33495ce25d1"),
    "dcg_slots": (lambda: _dcg(), 16, "b038ddf30fc19ca6"),
    "dcg_area_mix": (lambda: _dcg(reward_area=3, min_reward_area=1, history=3), None, "be5bda224cfef6a3"),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_trajectories_are_pinned(name):
    make, slots, expected = CASES[name]
    env, params = make()
    assert _digest(env, params, slots) == expected
