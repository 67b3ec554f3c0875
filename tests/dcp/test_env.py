"""jaxdc.dcp.env: the DCP transition rules of section 4.3 on hand-made states, reset, risk statistics and
invariants (batching and jit: test_env_batching.py; bad input: test_env_hostile.py)."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from jaxdc.dcp.env import CLEARED, DCP, ENERGY, IDLE, RISK, RUNNING, TRUNCATED, EnvParams
from tests.support.draws import assert_power_law
from tests.support.states import make_state, risk_with

A = {"stay": 0, "up": 1, "down": 2, "left": 3, "right": 4, "up_left": 5, "up_right": 6, "down_left": 7,
     "down_right": 8}
KEY = jax.random.PRNGKey(0)

ENV = DCP(grid_size=4, total_reward=3)
STEP = jax.jit(ENV.step_env)
ENV_IDLE = DCP(grid_size=4, total_reward=3, idle_terminates=True)
STEP_IDLE = jax.jit(ENV_IDLE.step_env)


def params(env=ENV, cells=None, energy=(10.0, 10.0), max_steps=1000):
    return env.make_params(risk_with(env.grid_size, cells), energy, max_steps)


def step(state, action, p=None, env=ENV, key=KEY):
    fn = STEP if env is ENV else STEP_IDLE if env is ENV_IDLE else jax.jit(env.step_env)
    return fn(key, state, jnp.int32(action), params(env) if p is None else p)


# ----------------------------------------------------------------------------------------------
# transitions on hand-made states
# ----------------------------------------------------------------------------------------------


def test_move_collect_energy_and_observation():
    s = make_state(ENV, (1, 1), 5, {(2, 2): 2, (0, 3): 1})
    obs, s2, r, term, trunc, info = step(s, A["down_right"])
    assert tuple(np.asarray(s2.pos)) == (2, 2)
    assert float(r) == 2.0
    assert float(s2.items[2, 2]) == 0.0 and float(s2.items[0, 3]) == 1.0
    assert float(s2.energy) == 4.0
    assert int(s2.time) == 1 and int(s2.outcome) == RUNNING
    assert float(s2.ep_reward) == 2.0 and int(s2.ep_energy) == 1
    assert not bool(term) and not bool(trunc)
    assert int(info["outcome"]) == RUNNING
    # observation planes: M^item and M^agent (energy at the agent's cell)
    obs = np.asarray(obs)
    assert obs.shape == (4, 4, 2) == ENV.observation_shape()
    expected_items = np.zeros((4, 4))
    expected_items[0, 3] = 1
    np.testing.assert_array_equal(obs[..., 0], expected_items)
    expected_agent = np.zeros((4, 4))
    expected_agent[2, 2] = 4.0
    np.testing.assert_array_equal(obs[..., 1], expected_agent)


def test_collect_on_disabling_step_still_rewards():
    p = params(cells={(2, 2): 1.0})
    s = make_state(ENV, (1, 1), 5, {(2, 2): 3, (0, 3): 1})
    _, s2, r, term, trunc, info = step(s, A["down_right"], p)
    assert float(r) == 3.0 and float(s2.ep_reward) == 3.0
    assert bool(term) and not bool(trunc)
    assert int(s2.outcome) == RISK == int(info["outcome"])


def test_risk_precedes_energy_death():
    # risk is rolled before the energy decrement (section 4.3): a risk-1 cell with energy 1 -> RISK
    p = params(cells={(2, 2): 1.0})
    s = make_state(ENV, (1, 1), 1, {(0, 3): 1})
    _, s2, _, term, _, _ = step(s, A["down_right"], p)
    assert bool(term) and int(s2.outcome) == RISK


def test_energy_refill_in_base():
    p = params(energy=(3.0, 12.0))
    s = make_state(ENV, (0, 1), 1, {(3, 3): 1})
    _, s2, _, term, _, _ = step(s, A["left"], p)
    assert tuple(np.asarray(s2.pos)) == (0, 0)
    assert float(s2.energy) == 12.0 and not bool(term)
    # staying in the base keeps it at the maximum
    _, s3, _, term, _, _ = step(s2, A["stay"], p)
    assert float(s3.energy) == 12.0 and not bool(term)


def test_energy_decrements_and_death_at_zero():
    p = params(energy=(3.0, 12.0))
    s = make_state(ENV, (1, 1), 2, {(3, 3): 1, (1, 2): 2})
    _, s2, _, term, _, _ = step(s, A["stay"], p)  # staying outside the base costs energy too
    assert float(s2.energy) == 1.0 and not bool(term) and int(s2.outcome) == RUNNING
    _, s3, r, term, trunc, _ = step(s2, A["right"], p)  # collects, then runs dry
    assert float(r) == 2.0 and float(s3.ep_reward) == 2.0
    assert float(s3.energy) == 0.0
    assert bool(term) and not bool(trunc) and int(s3.outcome) == ENERGY


def test_risk_zero_never_disables():
    keys = jax.random.split(jax.random.PRNGKey(1), 2000)
    s = make_state(ENV, (1, 1), 5, {(3, 3): 1})
    p = params()
    out = jax.vmap(lambda k: ENV.step_env(k, s, jnp.int32(A["down_right"]), p)[1].outcome)(keys)
    assert np.all(np.asarray(out) == RUNNING)


def test_risk_one_always_disables():
    keys = jax.random.split(jax.random.PRNGKey(2), 500)
    s = make_state(ENV, (1, 1), 5, {(3, 3): 1})
    p = params(cells={(2, 2): 1.0})
    out = jax.vmap(lambda k: ENV.step_env(k, s, jnp.int32(A["down_right"]), p)[1].outcome)(keys)
    assert np.all(np.asarray(out) == RISK)


def test_cleared_when_last_item_collected():
    s = make_state(ENV, (1, 1), 5, {(1, 2): 1})
    _, s2, r, term, trunc, _ = step(s, A["right"])
    assert float(r) == 1.0 and bool(term) and not bool(trunc) and int(s2.outcome) == CLEARED
    # not cleared while another item remains
    s = make_state(ENV, (1, 1), 5, {(1, 2): 1, (3, 0): 1})
    _, s2, _, term, _, _ = step(s, A["right"])
    assert not bool(term) and int(s2.outcome) == RUNNING


def test_step_cap_truncates_not_terminates():
    p = params(max_steps=3)
    s = make_state(ENV, (1, 1), 5, {(3, 3): 1}, time=1)
    _, s2, _, term, trunc, _ = step(s, A["stay"], p)
    assert int(s2.time) == 2 and not bool(trunc) and not bool(term)
    _, s3, _, term, trunc, info = step(s2, A["stay"], p)
    assert int(s3.time) == 3
    assert bool(trunc) and not bool(term) and int(s3.outcome) == TRUNCATED == int(info["outcome"])
    # a terminal state on the capped step is a termination
    s = make_state(ENV, (1, 1), 5, {(1, 2): 1}, time=2)
    _, s4, _, term, trunc, _ = step(s, A["right"], p)
    assert bool(term) and not bool(trunc) and int(s4.outcome) == CLEARED


def test_idle_terminates_only_when_enabled():
    p = params(ENV_IDLE, energy=(10.0, 10.0))
    base_full = make_state(ENV_IDLE, (0, 0), 10, {(3, 3): 1})
    _, s2, _, term, trunc, _ = step(base_full, A["up_left"], p, env=ENV_IDLE)  # clipped: no move
    assert bool(term) and not bool(trunc) and int(s2.outcome) == IDLE
    _, s2, _, term, _, _ = step(base_full, A["stay"], params(ENV), env=ENV)
    assert not bool(term) and int(s2.outcome) == RUNNING
    # in the base with energy below the maximum: the refill changes the state
    _, s2, _, term, _, _ = step(make_state(ENV_IDLE, (0, 0), 4, {(3, 3): 1}), A["stay"], p, env=ENV_IDLE)
    assert not bool(term) and float(s2.energy) == 10.0
    # outside the base energy drops: not idle
    _, s2, _, term, _, _ = step(make_state(ENV_IDLE, (2, 2), 4, {(3, 3): 1}), A["stay"], p, env=ENV_IDLE)
    assert not bool(term) and int(s2.outcome) == RUNNING
    # a move is never idle
    _, s2, _, term, _, _ = step(base_full, A["right"], p, env=ENV_IDLE)
    assert not bool(term)
    # infinite energy outside the base: staying is unchanged -> idle
    pinf = params(ENV_IDLE, energy=(math.inf, math.inf))
    _, s2, _, term, _, _ = step(make_state(ENV_IDLE, (2, 2), math.inf, {(3, 3): 1}), A["stay"], pinf, env=ENV_IDLE)
    assert bool(term) and int(s2.outcome) == IDLE


@pytest.mark.parametrize("metric, expected", [("not_stay_in_base", [0, 1, 2]), ("outside_base", [0, 1, 1]),
                                              ("all_steps", [1, 2, 3])])
def test_energy_metrics(metric, expected):
    env = DCP(grid_size=4, total_reward=3, energy_metric=metric)
    p = env.make_params(risk_with(4), (10.0, 10.0))
    s = make_state(env, (0, 0), 10, {(3, 3): 1})
    fn = jax.jit(env.step_env)
    got = []
    for a in (A["stay"], A["right"], A["left"]):  # base->base, base->(0,1), (0,1)->base
        _, s, _, term, _, info = fn(KEY, s, jnp.int32(a), p)
        assert not bool(term)
        got.append(int(s.ep_energy))
        assert int(info["episode_energy"]) == got[-1]
    assert got == expected


def test_auto_reset_keeps_final_observation():
    p = params(cells={(2, 2): 1.0})
    s = make_state(ENV, (1, 1), 5, {(2, 2): 3, (0, 3): 1})
    k = jax.random.PRNGKey(7)
    obs, s2, r, term, trunc, info = jax.jit(ENV.step)(k, s, jnp.int32(A["down_right"]), p)
    assert bool(term) and float(r) == 3.0
    final = np.asarray(info["final_observation"])
    assert final[2, 2, 1] == 4.0 and final[2, 2, 0] == 0.0 and final[0, 3, 0] == 1.0
    # the new episode: fresh state, and obs is its observation
    assert int(s2.time) == 0 and int(s2.outcome) == RUNNING and float(s2.ep_reward) == 0.0
    assert float(s2.energy) == 10.0 and float(np.asarray(s2.items).sum()) == 3.0
    np.testing.assert_array_equal(np.asarray(obs), np.asarray(ENV.observe(s2, p)))
    assert not np.array_equal(np.asarray(obs), final)
    # a non-terminal step: no reset, final_observation == obs
    obs, s3, *_, info = jax.jit(ENV.step)(k, s, jnp.int32(A["up"]), p)
    assert int(s3.time) == 1 and tuple(np.asarray(s3.pos)) == (0, 1)
    np.testing.assert_array_equal(np.asarray(info["final_observation"]), np.asarray(obs))


# ----------------------------------------------------------------------------------------------
# reset
# ----------------------------------------------------------------------------------------------


def _resets(env, n, seed=0, p=None):
    p = env.make_params("high", (8.0, 16.0)) if p is None else p
    keys = jax.random.split(jax.random.PRNGKey(seed), n)
    return jax.jit(jax.vmap(env.reset_env, in_axes=(0, None)))(keys, p)


def test_reset_random_free_never_on_item():
    env = DCP(grid_size=4, total_reward=15)  # 16 cells, at most 15 occupied: a free cell always exists
    obs, s = _resets(env, 1000)
    pos, items = np.asarray(s.pos), np.asarray(s.items)
    on = items[np.arange(1000), pos[:, 0], pos[:, 1]]
    assert np.all(on == 0)
    assert np.all(np.asarray(s.energy) == 8.0) and np.all(np.asarray(s.time) == 0)
    # the observation is the two planes of the state
    np.testing.assert_array_equal(np.asarray(obs)[..., 0], items)
    assert np.all(np.asarray(obs)[np.arange(1000), pos[:, 0], pos[:, 1], 1] == 8.0)
    # several start cells are used
    assert len({tuple(x) for x in pos}) > 5


def test_reset_base():
    env = DCP(grid_size=5, total_reward=10, start="base")
    _, s = _resets(env, 200)
    assert np.all(np.asarray(s.pos) == 0)


def test_reset_multinomial_uniform():
    n, total, m = 4, 30, 2000
    env = DCP(grid_size=n, total_reward=total)
    _, s = _resets(env, m, seed=3)
    items = np.asarray(s.items)
    assert np.all(items.reshape(m, -1).sum(axis=1) == total)
    assert np.all(items == np.round(items)) and np.all(items >= 0)
    counts = items.sum(axis=0).ravel()
    chi2 = stats.chisquare(counts, np.full(n * n, total * m / (n * n)))
    assert chi2.pvalue > 1e-4, chi2
    # per-episode counts per cell ~ Binomial(total, 1/N^2): mean 30/16
    assert abs(items[:, 1, 1].mean() - total / n**2) < 4 * math.sqrt(total / n**2 * (1 - 1 / n**2) / m)


def test_reset_min_total_reward_draws_the_total_uniformly():
    m = 3000
    _, s = _resets(DCP(grid_size=4, total_reward=6, min_total_reward=2), m, seed=4)
    totals = np.asarray(s.items).reshape(m, -1).sum(axis=1).astype(int)
    counts = np.bincount(totals, minlength=7)
    assert counts[:2].sum() == 0 and counts.sum() == m  # always 2..6 units
    assert stats.chisquare(counts[2:]).pvalue > 1e-4, counts
    # min_total_reward == total_reward is the fixed drop
    _, s = _resets(DCP(grid_size=4, total_reward=6, min_total_reward=6), 50)
    assert np.all(np.asarray(s.items).reshape(50, -1).sum(axis=1) == 6)


@pytest.mark.parametrize("tilt", [1.0, 2.0, -0.5])
def test_reset_item_tilt_draws_the_total_by_its_power_law(tilt):
    """``item_tilt`` (beyond the thesis): each unit count ``c`` of ``min_total_reward..total_reward`` has the mass of
    ``x ** -tilt`` over ``[c, c + 1)`` (the draw of :func:`jaxdc.core.sampling.power_law_integer`)."""
    m = 6000
    _, s = _resets(DCP(grid_size=4, total_reward=12, min_total_reward=2, item_tilt=tilt), m, seed=5)
    totals = np.asarray(s.items).reshape(m, -1).sum(axis=1)
    expected = assert_power_law(totals, 2, 12, tilt)
    assert (expected[0] > 1 / 11) == (tilt > 0)  # a positive tilt weights the few items, a negative one the many


def test_reset_item_tilt_zero_is_the_uniform_draw():
    """``item_tilt=0`` is the same environment as without it: the same episodes for the same keys."""
    plain, zero = DCP(grid_size=4, total_reward=6, min_total_reward=2), DCP(grid_size=4, total_reward=6,
                                                                            min_total_reward=2, item_tilt=0.0)
    assert plain == zero and repr(plain) == repr(zero)
    a, b = _resets(plain, 50, seed=6)[1], _resets(zero, 50, seed=6)[1]
    np.testing.assert_array_equal(np.asarray(a.items), np.asarray(b.items))
    assert DCP(grid_size=4, total_reward=6, min_total_reward=2, item_tilt=1.0) != plain


def test_reset_items_on_base_off():
    env = DCP(grid_size=3, total_reward=20, items_on_base=False)
    _, s = _resets(env, 300)
    items = np.asarray(s.items)
    assert np.all(items[:, 0, 0] == 0) and np.all(items.reshape(300, -1).sum(1) == 20)


def test_reset_drop_rank():
    total = 6
    env = DCP(grid_size=4, total_reward=total, item_order="drop")
    _, s = _resets(env, 300, seed=5)
    items, rank = np.asarray(s.items).reshape(300, -1), np.asarray(s.rank).reshape(300, -1)
    orders = set()
    for it, rk in zip(items, rank):
        r = rk[it > 0]
        assert len(set(r.tolist())) == r.size  # distinct
        assert np.all((r >= 0) & (r < total))
        assert r.min() == 0  # the first unit dropped has rank 0
        assert r.max() <= total - r.size + r.size - 1
        orders.add(tuple(np.argsort(r)))
    # drop order is random, not row-major
    assert len(orders) > 10
    env2 = DCP(grid_size=4, total_reward=total, item_order="row_major")
    _, s2 = _resets(env2, 5)
    np.testing.assert_array_equal(np.asarray(s2.rank)[0], np.arange(16).reshape(4, 4))


# ----------------------------------------------------------------------------------------------
# risk statistics
# ----------------------------------------------------------------------------------------------


def test_empirical_death_rate_matches_risk():
    m, rho = 20_000, 0.3
    p = params(cells={(1, 1): rho})
    s = make_state(ENV, (1, 2), 5, {(3, 3): 1})
    keys = jax.random.split(jax.random.PRNGKey(11), m)
    out = jax.jit(jax.vmap(lambda k: ENV.step_env(k, s, jnp.int32(A["left"]), p)[1].outcome))(keys)
    rate = float(np.mean(np.asarray(out) == RISK))
    se = math.sqrt(rho * (1 - rho) / m)
    assert abs(rate - rho) < 4 * se, rate
    assert np.all(np.isin(np.asarray(out), [RISK, RUNNING]))


# ----------------------------------------------------------------------------------------------
# invariants under hypothesis
# ----------------------------------------------------------------------------------------------

INV_ENV = DCP(grid_size=5, total_reward=10)
INV_STEPS = 30


@jax.jit
def _random_rollout(key, risk, init_e, max_e):
    p = EnvParams(risk=risk, init_energy=init_e, max_energy=max_e, max_steps=jnp.int32(1000))
    k0, k1 = jax.random.split(key)
    _, s = INV_ENV.reset_env(k0, p)

    def body(s, k):
        ka, ks = jax.random.split(k)
        a = jax.random.randint(ka, (), 0, 9)
        _, s2, r, term, trunc, _ = INV_ENV.step(ks, s, a, p)
        return s2, (s2, r)

    _, (states, rewards) = jax.lax.scan(body, s, jax.random.split(k1, INV_STEPS))
    return states, rewards


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    risk=st.lists(st.sampled_from([0.0, 0.01, 0.1, 0.3, 0.64, 1.0]), min_size=25, max_size=25),
    init_e=st.integers(1, 20),
    extra=st.integers(0, 10),
    infinite=st.booleans(),
)
def test_invariants_random_actions(seed, risk, init_e, extra, infinite):
    r = np.asarray(risk, np.float32).reshape(5, 5)
    r[0, 0] = 0
    max_e = math.inf if infinite else float(init_e + extra)
    init = math.inf if infinite else float(init_e)
    states, rewards = _random_rollout(jax.random.PRNGKey(seed), jnp.asarray(r), jnp.float32(init), jnp.float32(max_e))
    energy = np.asarray(states.energy)
    if infinite:
        assert np.all(np.isinf(energy))
    else:
        assert np.all((energy >= 0) & (energy <= max_e))
    assert np.all(np.asarray(rewards) >= 0)
    assert np.all(np.asarray(states.ep_reward) <= INV_ENV.total_reward)
    assert np.all(np.asarray(states.items) >= 0)
    assert np.all(np.asarray(states.ep_energy) <= np.asarray(states.time))
    assert np.all(np.asarray(states.ep_reward) + np.asarray(states.items).sum((1, 2)) == INV_ENV.total_reward)


def test_energy_never_negative_with_fractional_energy():
    # energy is clamped at 0 when the agent is disabled by it (a fractional budget must not go negative)
    p = ENV.make_params(risk_with(4), (0.5, 1.0))
    s = make_state(ENV, (1, 1), 0.5, {(3, 3): 1})
    _, s2, _, term, _, _ = step(s, A["stay"], p)
    assert bool(term) and int(s2.outcome) == ENERGY
    assert float(s2.energy) >= 0.0
