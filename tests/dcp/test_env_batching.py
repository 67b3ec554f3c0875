"""jaxdc.dcp.env under jit, vmap and scan: a batch equals a Python loop, no retracing, a batch over risk maps,
determinism by seed."""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.dcp.env import DCP
from jaxdc.dcp.types import RISK, RUNNING
from tests.support.states import make_state, risk_with

A = {"stay": 0, "up": 1, "down": 2, "left": 3, "right": 4, "up_left": 5, "up_right": 6, "down_left": 7,
     "down_right": 8}
KEY = jax.random.PRNGKey(0)
ENV = DCP(grid_size=4, total_reward=3)


def _resets(env, n, seed=0, p=None):
    p = env.make_params("high", (8.0, 16.0)) if p is None else p
    keys = jax.random.split(jax.random.PRNGKey(seed), n)
    return jax.jit(jax.vmap(env.reset_env, in_axes=(0, None)))(keys, p)


BENV = DCP(grid_size=5, total_reward=8)
BPARAMS = BENV.make_params("high", (3.0, 6.0), max_steps=20)
B_STEP = jax.jit(BENV.step)
B_VSTEP = jax.jit(jax.vmap(BENV.step, in_axes=(0, 0, 0, None)))


def test_jit_vmap_equals_python_loop():
    b = 8
    keys = jax.random.split(jax.random.PRNGKey(3), b)
    _, states = jax.vmap(BENV.reset_env, in_axes=(0, None))(keys, BPARAMS)
    rng = np.random.default_rng(0)
    for t in range(6):
        actions = jnp.asarray(rng.integers(0, 9, b), jnp.int32)
        skeys = jax.random.split(jax.random.PRNGKey(100 + t), b)
        out_v = B_VSTEP(skeys, states, actions, BPARAMS)
        for i in range(b):
            st_i = jax.tree_util.tree_map(lambda x, i=i: x[i], states)
            out_i = B_STEP(skeys[i], st_i, actions[i], BPARAMS)
            chex.assert_trees_all_close(jax.tree_util.tree_map(lambda x, i=i: x[i], out_v), out_i)
        states = out_v[1]


def test_no_retracing():
    traces = []

    @chex.assert_max_traces(n=1)
    def f(key, state, action, p):
        traces.append(1)
        return BENV.step(key, state, action, p)

    g = jax.jit(f)
    _, s = BENV.reset_env(KEY, BPARAMS)
    for i, risk in enumerate(("low", "medium", "high")):
        p = BENV.make_params(risk, (float(2 + i), 9.0), max_steps=10 + i)
        out = g(jax.random.PRNGKey(i), s, jnp.int32(i), p)
        s = out[1]
    assert len(traces) == 1


def test_vmap_over_params_two_risk_maps():
    pa = ENV.make_params(risk_with(4, {(1, 1): 1.0}), (5.0, 9.0))
    pb = ENV.make_params(risk_with(4), (5.0, 9.0))
    pp = jax.tree_util.tree_map(lambda a, b: jnp.stack([a, b]), pa, pb)
    s = make_state(ENV, (1, 2), 5, {(3, 3): 1})
    ss = jax.tree_util.tree_map(lambda x: jnp.stack([x, x]), s)
    out = jax.jit(jax.vmap(ENV.step_env, in_axes=(None, 0, None, 0)))(KEY, ss, jnp.int32(A["left"]), pp)
    assert list(np.asarray(out[1].outcome)) == [RISK, RUNNING]
    assert list(np.asarray(out[3])) == [True, False]


def test_runs_inside_scan_and_matches_loop():
    _, s0 = BENV.reset_env(jax.random.PRNGKey(4), BPARAMS)
    keys = jax.random.split(jax.random.PRNGKey(5), 25)
    actions = jnp.asarray(np.random.default_rng(1).integers(0, 9, 25), jnp.int32)

    @jax.jit
    def scan(s):
        def body(s, xs):
            k, a = xs
            _, s2, r, term, trunc, _ = BENV.step(k, s, a, BPARAMS)
            return s2, (r, term | trunc)

        return jax.lax.scan(body, s, (keys, actions))

    s_end, (rewards, dones) = scan(s0)
    s = s0
    for t in range(25):
        _, s, r, term, trunc, _ = B_STEP(keys[t], s, actions[t], BPARAMS)
        assert float(r) == float(rewards[t]) and bool(term | trunc) == bool(dones[t])
    chex.assert_trees_all_close(s, s_end)


def test_determinism_by_seed():
    a = _resets(BENV, 16, seed=9)
    b = _resets(BENV, 16, seed=9)
    c = _resets(BENV, 16, seed=10)
    chex.assert_trees_all_equal(a, b)
    assert not np.array_equal(np.asarray(a[1].items), np.asarray(c[1].items))
    s = jax.tree_util.tree_map(lambda x: x[0], a[1])
    o1 = B_STEP(jax.random.PRNGKey(1), s, jnp.int32(2), BPARAMS)
    o2 = B_STEP(jax.random.PRNGKey(1), s, jnp.int32(2), BPARAMS)
    chex.assert_trees_all_equal(o1, o2)
