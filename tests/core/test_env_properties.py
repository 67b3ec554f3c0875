"""Property test over both environments: for random valid parameters (unlimited energy included) and random
actions (out-of-range ones included), every observation, reward and info value is finite and every observation
lies in the environment's observation space."""

import math

import jax
import jax.numpy as jnp
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jaxdc.dcg.env import DCG
from jaxdc.dcp.env import DCP

STEPS = 64
# A few static configurations (each compiles once); the numeric parameters vary freely as traced leaves.
DCPS = [DCP(grid_size=3, total_reward=4), DCP(grid_size=6, total_reward=30, start="base", items_on_base=False)]
DCGS = [DCG(grid_size=4, total_reward=3, history=2), DCG(grid_size=6, strategies=("with_fog", "double_blind"))]

energy = st.one_of(st.just(math.inf), st.floats(0.5, 40.0, allow_nan=False))


def _rollout(env):
    @jax.jit
    def run(key, params, actions):
        obs, state = env.reset(key, params)

        def body(carry, xs):
            obs, state = carry
            k, a = xs
            obs, state, reward, term, trunc, info = env.step(k, state, a, params)
            values = [obs, info["final_observation"], reward.astype(jnp.float32)] + [
                jnp.asarray(v, jnp.float32) for k_, v in sorted(info.items()) if k_ != "final_observation"]
            finite = jnp.all(jnp.stack([jnp.all(jnp.isfinite(v)) for v in values]))
            return (obs, state), (finite, obs, info["final_observation"])

        keys = jax.random.split(key, actions.shape[0])
        _, out = jax.lax.scan(body, (obs, state), (keys, actions))
        return obs, out

    return run


RUNS = {id(e): _rollout(e) for e in DCPS + DCGS}


def _check(env, params, seed, actions):
    space = env.observation_space(params)
    obs0, (finite, seen, final) = RUNS[id(env)](jax.random.PRNGKey(seed), params, jnp.asarray(actions, jnp.int32))
    assert bool(jnp.all(finite))
    for o in (obs0[None], seen, final):
        o = np.asarray(o)
        assert np.all(o >= space.low) and np.all(o <= space.high)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(which=st.integers(0, len(DCPS) - 1), e0=energy, extra=energy, risk=st.floats(0.0, 1.0),
       max_steps=st.integers(1, 200), seed=st.integers(0, 2**32 - 1),
       actions=st.lists(st.integers(-3, 12), min_size=STEPS, max_size=STEPS))
def test_dcp_values_are_always_finite(which, e0, extra, risk, max_steps, seed, actions):
    env = DCPS[which]
    n = env.grid_size
    risk_map = np.full((n, n), risk, np.float32)
    risk_map[0, 0] = 0.0
    init, top = sorted((e0, extra))
    _check(env, env.make_params(risk=risk_map, energy=(init, top), max_steps=max_steps), seed, actions)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(which=st.integers(0, len(DCGS) - 1), e=energy, max_steps=st.integers(1, 200),
       seed=st.integers(0, 2**32 - 1), actions=st.lists(st.integers(-3, 12), min_size=STEPS, max_size=STEPS))
def test_dcg_values_are_always_finite(which, e, max_steps, seed, actions):
    env = DCGS[which]
    _check(env, env.make_params(energy=e, max_steps=max_steps), seed, actions)
