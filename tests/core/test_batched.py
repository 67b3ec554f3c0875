"""core.batched: the batch step with batch-level random numbers plays the same episodes, in distribution, as
``vmap(env.step)`` (issue 30). Each check is a two-sample test over a few thousand finished episodes, at a level
that a real change of the rules fails: the last tests apply the same check to a slightly changed environment and
require it to be rejected."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from jaxdc.core import generators
from jaxdc.core.batched import reset_batched, step_batched
from jaxdc.core.env import step_batch
from jaxdc.dcg.env import DCG
from jaxdc.dcg.team import DCGTeam
from jaxdc.dcp.env import DCP
from jaxdc.dcp.instances import instance_params

#: A p-value below this rejects "the same distribution": the tests are deterministic (fixed seeds), and the
#: changed environments below are rejected far below it.
ALPHA = 1e-3


def _episodes(env, params, stepper, seed: int, batch: int = 512, steps: int = 200) -> dict[str, np.ndarray]:
    """The finished episodes of ``steps`` random-policy steps of ``batch`` environments, stepped by ``stepper``
    (``"per_env"``: ``vmap(env.step)``; ``"batched"``: :func:`step_batched`): reward, length, energy, outcome."""

    @jax.jit
    def run(key):
        k0, k_loop = jax.random.split(key)
        obs, state = reset_batched(env, k0, batch, params)

        def body(state, k):
            k_act, k_step = jax.random.split(k)
            action = jax.random.randint(k_act, (batch,) + (env.action_shape or ()), 0, env.num_actions)
            step = step_batched if stepper == "batched" else step_batch
            _, state, _, term, trunc, info = step(env, k_step, state, action, params)
            return state, (term | trunc, info["episode_reward"], info["episode_steps"], info["episode_energy"],
                           info["outcome"])

        _, out = jax.lax.scan(body, state, jax.random.split(k_loop, steps))
        return out

    done, reward, length, energy, outcome = (np.asarray(x) for x in run(jax.random.key(seed)))
    return {"reward": reward[done], "length": length[done], "energy": energy[done], "outcome": outcome[done]}


def _p_values(a: dict, b: dict) -> dict[str, float]:
    """Two-sample p-values, per statistic: Kolmogorov-Smirnov for the reward, length and energy (discrete, so
    the test is conservative), chi-square on the outcome counts."""
    out = {k: stats.ks_2samp(a[k], b[k]).pvalue for k in ("reward", "length", "energy")}
    names = np.union1d(a["outcome"], b["outcome"])
    table = np.array([[np.sum(x["outcome"] == o) for o in names] for x in (a, b)])
    out["outcome"] = stats.chi2_contingency(table).pvalue if len(names) > 1 else 1.0
    return out


def _dcp():
    env = DCP(grid_size=8, total_reward=30)
    return env, env.make_params("high", (8.0, 16.0), max_steps=200)


def _dcp_instances():
    env = DCP(grid_size=6, total_reward=10, min_total_reward=1, observation="general")
    maps = generators.make_maps(generators.generator("mix"), generators.SeedSet(0, 16), 6)
    return env, instance_params(env, maps, (6.0, 24.0), max_steps=100)


def _dcg():
    env = DCG()
    return env, env.make_params(energy=15.0, max_steps=100, chase_tie="random")


def _team():
    env = DCGTeam(collectors=2)
    return env, env.make_params(energy=15.0, max_steps=100)


CASES = {"dcp_table_4.3": _dcp, "dcp_per_episode_maps": _dcp_instances, "dcg": _dcg, "dcg_team": _team}


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(CASES))
def test_batched_episodes_have_the_per_env_distribution(case):
    env, params = CASES[case]()
    a = _episodes(env, params, "per_env", seed=1)
    b = _episodes(env, params, "batched", seed=2)
    assert min(len(a["reward"]), len(b["reward"])) > 1000, "too few finished episodes for the test"
    p = _p_values(a, b)
    assert min(p.values()) > ALPHA, p


@pytest.mark.slow
@pytest.mark.parametrize("case", ["dcp_table_4.3", "dcg"])
def test_the_same_check_rejects_a_changed_environment(case):
    """The check has power: the same comparison fails against a game whose rules changed a little (the DCP's
    risk scaled by 0.85; the DCG's maximum energy 14 instead of 15)."""
    env, params = CASES[case]()
    if case == "dcg":
        changed = env.make_params(energy=14.0, max_steps=100, chase_tie="random")
    else:
        changed = env.make_params(np.asarray(params.risk) * 0.85, (8.0, 16.0), max_steps=200)
    a = _episodes(env, params, "per_env", seed=1)
    b = _episodes(env, changed, "batched", seed=2)
    assert min(_p_values(a, b).values()) < ALPHA


def test_the_per_env_step_is_its_noise_step():
    """``env.step_env(key, ...)`` equals ``step_with_noise(step_noise(key, None))``: the DCP's own streams are
    unchanged by the split (the trajectory pins, tests/core/test_trajectory_pin.py, check them too)."""
    env, params = _dcp()
    _, state = env.reset(jax.random.key(0), params)
    key = jax.random.key(3)
    for action in range(9):
        x = env.step_env(key, state, jnp.int32(action), params)
        y = env.step_with_noise(env.step_noise(key, None, params), state, jnp.int32(action), params)
        for u, v in zip(jax.tree_util.tree_leaves(x), jax.tree_util.tree_leaves(y)):
            np.testing.assert_array_equal(np.asarray(u), np.asarray(v))


def test_step_batched_resets_only_the_finished_and_is_deterministic():
    env = DCP(grid_size=4, total_reward=3)
    risk = np.ones((4, 4), np.float32)
    risk[0, 0] = 0.0  # every step off the base ends the episode
    params = env.make_params(risk, (5.0, 5.0), max_steps=50)
    _, state = reset_batched(env, jax.random.key(0), 16, params)
    action = jnp.zeros(16, jnp.int32)  # stay
    step = jax.jit(lambda k, s, a: step_batched(env, k, s, a, params))
    obs, s2, _, term, trunc, info = step(jax.random.key(1), state, action)
    done = np.asarray(term | trunc)
    np.testing.assert_array_equal(done, ~np.all(np.asarray(state.pos) == 0, axis=1))
    assert np.all(np.asarray(s2.time)[done] == 0) and np.all(np.asarray(s2.time)[~done] == 1)
    np.testing.assert_array_equal(np.asarray(info["final_observation"])[~done], np.asarray(obs)[~done])
    fresh = np.asarray(s2.items)[done]
    assert len({f.tobytes() for f in fresh}) == len(fresh)  # independent initial states
    again = step(jax.random.key(1), state, action)
    for u, v in zip(jax.tree_util.tree_leaves((obs, s2)), jax.tree_util.tree_leaves(again[:2])):
        np.testing.assert_array_equal(np.asarray(u), np.asarray(v))


def test_step_batched_refuses_params_of_another_grid_size():
    env, _ = _dcp()
    _, state = reset_batched(env, jax.random.key(0), 4, env.default_params)
    other = DCP(grid_size=6).make_params()
    with pytest.raises(ValueError, match="grid size"):
        step_batched(env, jax.random.key(1), state, jnp.zeros(4, jnp.int32), other)


class _Bonus(DCP):
    """A DCP whose step pays one more unit: it overrides ``step_env`` below the class that wrote the noise hooks."""

    def step_env(self, key, state, action, params):
        obs, new_state, reward, terminated, truncated, info = super().step_env(key, state, action, params)
        return obs, new_state, reward + 1.0, terminated, truncated, info


def test_an_override_of_step_env_below_the_noise_hooks_is_stepped():
    env = _Bonus(grid_size=4, total_reward=3)
    params = env.make_params("low", (5.0, 10.0), max_steps=20)
    _, state = reset_batched(env, jax.random.key(0), 8, params)
    reward = step_batched(env, jax.random.key(1), state, jnp.zeros(8, jnp.int32), params)[2]
    assert np.all(np.asarray(reward) >= 1.0)  # the override's unit, on every environment


def test_an_empty_or_non_integer_batch_is_refused_by_name():
    env, params = _dcp()
    _, state = reset_batched(env, jax.random.key(0), 2, params)
    empty = jax.tree_util.tree_map(lambda x: x[:0], state)
    with pytest.raises(ValueError, match="action"):
        step_batched(env, jax.random.key(1), empty, jnp.zeros(0, jnp.int32), params)
    for bad in (0, -3, 2.5, "4"):
        with pytest.raises((ValueError, TypeError), match="batch"):
            reset_batched(env, jax.random.key(0), bad, params)
