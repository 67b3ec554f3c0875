"""The gymnasium adapters: env checker, key scheme, determinism, render, vector env, registration."""

import warnings

import gymnasium
import jax
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import AutoresetMode

import jaxdc
from jaxdc.core.env import Environment
from jaxdc.dcp.env import DCP, OUTCOMES
from jaxdc.wrappers.gymnasium import JaxToGymnasium, JaxVectorEnv, make_dcp

ID = "jaxdc/DCP-v0"


def rollout(env, seed, steps=20, action_seed=0):
    rng = np.random.default_rng(action_seed)
    obs, _ = env.reset(seed=seed)
    traj = [obs]
    rewards = []
    for _ in range(steps):
        obs, r, term, trunc, _ = env.step(int(rng.integers(9)))
        traj.append(obs)
        rewards.append(r)
        if term or trunc:
            obs, _ = env.reset()
            traj.append(obs)
    return np.stack(traj), np.array(rewards)


# -- registration and the env checker --------------------------------------------------------


def test_registered_and_reimport_safe():
    import importlib

    assert ID in gymnasium.registry
    importlib.reload(jaxdc)  # registering again must not raise
    assert ID in gymnasium.registry
    assert jaxdc.__version__ == "0.1.0"


CHECK_ENV_CASES = [
    (ID, {}, (8, 8, 2)),
    (ID, {"render_mode": "ansi"}, (8, 8, 2)),
    (ID, {"grid_size": 5, "risk": "low", "render_mode": "rgb_array"}, (5, 5, 2)),
    (ID, {"energy": (float("inf"), float("inf"))}, (8, 8, 2)),
    ("jaxdc/DCG-v0", {}, (5, 5, 12)),
    ("jaxdc/DCG-v0", {"render_mode": "ansi", "strategies": ("patrol", "restricted", "double_blind")}, (5, 5, 12)),
    ("jaxdc/DCG-v0", {"grid_size": 4, "history": 2, "obs_history": False, "render_mode": "rgb_array"}, (4, 4, 2)),
]


@pytest.mark.parametrize("env_id,kwargs,shape", CHECK_ENV_CASES)
def test_check_env(env_id, kwargs, shape):
    env = gymnasium.make(env_id, **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # finite bounds: no "infinite bound" advisory, no other warning
        check_env(env.unwrapped)
    assert env.observation_space.shape == shape and np.all(np.isfinite(env.observation_space.high))
    assert env.action_space == gymnasium.spaces.Discrete(9)
    if env_id != ID:
        return
    n = shape[0]
    obs, info = env.reset(seed=3)
    assert obs.dtype == np.float32 and obs.shape == (n, n, 2)
    assert env.observation_space.contains(obs)


def test_make_kwargs_reach_dcp_and_params():
    env = gymnasium.make(ID, grid_size=5, risk="low", energy=(3.0, 5.0), total_reward=7, max_steps=4,
                         start="base", idle_terminates=True).unwrapped
    assert env.env == DCP(grid_size=5, total_reward=7, start="base", idle_terminates=True)
    np.testing.assert_array_equal(env.params.risk, DCP(5).make_params("low").risk)
    assert float(env.params.init_energy) == 3.0 and float(env.params.max_energy) == 5.0
    assert int(env.params.max_steps) == 4


def test_step_output_types_and_info():
    env = make_dcp(max_steps=3, risk="low", energy=(float("inf"), float("inf")))
    env.reset(seed=1)
    for t in range(3):
        obs, r, term, trunc, info = env.step(8)
        assert type(r) is float and type(term) is bool and type(trunc) is bool
        assert isinstance(obs, np.ndarray) and obs.dtype == np.float32
        assert env.observation_space.contains(obs)  # inf energy is inside the Box
        assert info["outcome"] in OUTCOMES and info["outcome_index"] == OUTCOMES.index(info["outcome"])
        assert isinstance(info["episode_steps"], int) and info["episode_steps"] == t + 1
    assert trunc and info["outcome"] == "truncated"


def test_invalid_inputs():
    with pytest.raises(ValueError, match="ansi"):
        make_dcp(render_mode="human")
    with pytest.raises(ValueError, match="rgb_array"):
        gymnasium.make(ID, render_mode="human")
    with pytest.raises(ValueError, match="writes scene"):
        JaxToGymnasium(_PlainEnv(), render_mode="rgb_array")
    with pytest.raises(ValueError, match="writes render_ansi"):
        JaxToGymnasium(_PlainEnv(), render_mode="ansi")
    with pytest.raises(ValueError, match="risk preset"):
        gymnasium.make(ID, risk="extreme")
    with pytest.raises(ValueError, match="grid_size"):
        gymnasium.make(ID, grid_size=1)
    with pytest.raises(ValueError, match="grid_size"):
        gymnasium.make_vec(ID, num_envs=2, vectorization_mode="vector_entry_point", grid_size=1)
    with pytest.raises(ValueError, match="risk preset"):
        jaxdc.make("DCP-v0", risk="extreme")
    with pytest.raises(ValueError, match="unknown environment id"):
        jaxdc.make("DCX-v0")
    env = make_dcp()
    with pytest.raises(RuntimeError):
        env.step(0)
    env.reset(seed=0)
    for bad in (9, -1, 1.5, "up"):
        with pytest.raises(ValueError, match="action"):
            env.step(bad)


def test_jaxdc_make_dcg():
    env, params = jaxdc.make("DCG-v0", grid_size=4, energy=10, max_steps=30)
    assert env.grid_size == 4 and int(params.max_steps) == 30
    obs, _ = env.reset(jax.random.PRNGKey(0), params)
    assert obs.shape[:2] == (4, 4)


def test_jaxdc_make():
    env, params = jaxdc.make("DCP-v0", grid_size=6, risk="medium", max_steps=50)
    assert isinstance(env, jaxdc.DCP) and env.grid_size == 6
    assert isinstance(params, jaxdc.DCPParams) and int(params.max_steps) == 50
    _, state = jax.eval_shape(env.reset, jax.random.PRNGKey(0), params)
    assert isinstance(state, jaxdc.DCPState)


# -- determinism and the key scheme -----------------------------------------------------------


def test_same_seed_same_trajectory_different_seed_differs():
    env_a, env_b = make_dcp(), make_dcp()
    obs_a, rew_a = rollout(env_a, seed=7)
    obs_b, rew_b = rollout(env_b, seed=7)
    np.testing.assert_array_equal(obs_a, obs_b)
    np.testing.assert_array_equal(rew_a, rew_b)
    obs_c, _ = rollout(env_a, seed=8)
    n = min(len(obs_a), len(obs_c))
    assert not np.array_equal(obs_a[:n], obs_c[:n])
    # re-seeding the same wrapper restarts the stream; an unseeded reset continues it
    obs_d, rew_d = rollout(env_a, seed=7)
    np.testing.assert_array_equal(obs_a, obs_d)
    first, _ = env_a.reset(seed=7)
    again, _ = env_a.reset()
    assert not np.array_equal(first, again)


def test_trajectory_matches_functional_env_by_hand():
    """Key scheme: key = PRNGKey(seed); each reset/step does key, sub = split(key) and uses sub."""
    dcp = DCP(grid_size=5)  # the config of other tests: shares their compiled step
    params = dcp.make_params(risk="medium", energy=(5.0, 9.0), max_steps=40)
    wrapped = JaxToGymnasium(dcp, params)
    reset_env, step_env = jax.jit(dcp.reset_env), jax.jit(dcp.step_env)
    rng = np.random.default_rng(3)

    key = jax.random.PRNGKey(11)
    key, sub = jax.random.split(key)
    obs_ref, state = reset_env(sub, params)
    obs, _ = wrapped.reset(seed=11)
    np.testing.assert_array_equal(obs, obs_ref)
    ends = 0
    for _ in range(60):
        a = int(rng.integers(9))
        key, sub = jax.random.split(key)
        obs_ref, state, r_ref, term_ref, trunc_ref, info_ref = step_env(sub, state, np.int32(a), params)
        obs, r, term, trunc, info = wrapped.step(a)
        np.testing.assert_array_equal(obs, obs_ref)
        assert r == float(r_ref) and term == bool(term_ref) and trunc == bool(trunc_ref)
        assert info["outcome"] == OUTCOMES[int(info_ref["outcome"])]
        if term or trunc:
            ends += 1
            key, sub = jax.random.split(key)
            obs_ref, state = reset_env(sub, params)
            obs, _ = wrapped.reset()
            np.testing.assert_array_equal(obs, obs_ref)
    assert ends >= 1  # the reset-without-seed path was exercised


def test_no_retrace_per_call():
    env = make_dcp(grid_size=5, risk="low")
    env.reset(seed=0)
    env.step(1)
    from jaxdc.wrappers import batched

    sizes = (batched.reset_one._cache_size(), batched.step_one._cache_size())
    for a in range(9):
        env.step(np.int64(a))
    env.reset(seed=5)
    env.reset()
    assert (batched.reset_one._cache_size(), batched.step_one._cache_size()) == sizes


# -- render ------------------------------------------------------------------------------


def test_ansi_render():
    env = make_dcp(grid_size=5, render_mode="ansi")
    for seed in range(20):
        env.reset(seed=seed)
        if tuple(np.asarray(env.state.pos)) != (0, 0):
            break
    text = env.render()
    lines = text.rstrip("\n").split("\n")
    assert len(lines) == 5 + 1  # grid rows + status line
    grid_rows = [row.split() for row in lines[:5]]
    assert all(len(row) == 5 for row in grid_rows)
    r, c = (int(x) for x in np.asarray(env.state.pos))
    assert grid_rows[r][c] == "A" and grid_rows[0][0] == "B"
    assert sum(row.count("A") for row in grid_rows) == 1
    items = np.asarray(env.state.items)
    for i in range(5):
        for j in range(5):
            if (i, j) not in ((r, c), (0, 0)):
                v = items[i, j]
                assert grid_rows[i][j] == ("." if v == 0 else "*" if v > 9 else str(int(v)))
    assert lines[5].startswith("energy 8/16") and "reward 0" in lines[5]
    assert make_dcp().render() is None  # no render_mode


def test_rgb_array_render():
    from jaxdc.viewer import cell_center
    from jaxdc.viewer.frame import frame_size

    env = gymnasium.make(ID, grid_size=5, render_mode="rgb_array").unwrapped
    env.reset(seed=1)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.shape == frame_size(5) + (3,)
    y, x = cell_center(5, *(int(v) for v in np.asarray(env.state.pos)))
    r, g, b = frame[y + 10, x].astype(int)  # inside the agent's disc, below its energy label
    assert b > r + 80
    assert env.metadata["render_modes"] == ["ansi", "rgb_array"]


# -- vector env ---------------------------------------------------------------------------


def test_make_vec_shapes_determinism_and_final_obs():
    venv = gymnasium.make_vec(ID, num_envs=4, vectorization_mode="vector_entry_point", grid_size=5, max_steps=15)
    assert isinstance(venv.unwrapped, JaxVectorEnv)
    assert venv.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    assert venv.num_envs == 4
    assert venv.single_action_space == gymnasium.spaces.Discrete(9)
    assert venv.action_space == gymnasium.spaces.MultiDiscrete([9] * 4)
    assert venv.single_observation_space.shape == (5, 5, 2)
    assert venv.observation_space.shape == (4, 5, 5, 2)

    obs, info = venv.reset(seed=2)
    obs2, _ = venv.reset(seed=2)
    obs3, _ = venv.reset(seed=3)
    assert obs.shape == (4, 5, 5, 2) and obs.dtype == np.float32
    np.testing.assert_array_equal(obs, obs2)
    assert not np.array_equal(obs, obs3)
    assert not np.array_equal(obs[0], obs[1])  # the copies get different keys

    def run(seed):
        venv.action_space.seed(seed)
        out = [venv.reset(seed=seed)[0]]
        done_steps = 0
        for _ in range(50):
            obs, rew, term, trunc, info = venv.step(venv.action_space.sample())
            assert obs.shape == (4, 5, 5, 2) and rew.shape == term.shape == trunc.shape == (4,)
            assert term.dtype == trunc.dtype == np.bool_
            assert venv.observation_space.contains(obs)
            done = term | trunc
            np.testing.assert_array_equal(info["_final_obs"], done)
            for i in range(4):
                if done[i]:
                    final = info["final_obs"][i]
                    assert final.shape == (5, 5, 2)
                    assert info["episode_steps"][i] >= 1
                    assert info["outcome"][i] != "running"
                    # same-step auto-reset: obs is a fresh episode (energy 8, full item count)
                    assert obs[i, ..., 0].sum() == 30 and obs[i, ..., 1].sum() == 8
                else:
                    assert info["final_obs"][i] is None
                    assert info["outcome"][i] == "running"
            assert trunc.sum() == (info["outcome"] == "truncated").sum()
            done_steps += done.sum()
            out.append(obs)
        return np.stack(out), done_steps

    traj_a, n_done = run(4)
    traj_b, _ = run(4)
    np.testing.assert_array_equal(traj_a, traj_b)
    assert n_done > 0  # 50 steps with a 15-step cap: episodes did end
    venv.close()


def test_vector_matches_functional_step():
    dcp = DCP(grid_size=5)  # the config of the make_vec test: shares its compiled step
    params = dcp.make_params(risk="high", energy=(3.0, 6.0), max_steps=10)
    venv = JaxVectorEnv(dcp, 4, params)
    vreset = jax.jit(jax.vmap(dcp.reset_env, in_axes=(0, None)))
    vstep = jax.jit(jax.vmap(dcp.step, in_axes=(0, 0, 0, None)))
    key = jax.random.PRNGKey(0)
    key, sub = jax.random.split(key)
    obs_ref, state = vreset(jax.random.split(sub, 4), params)
    obs, _ = venv.reset(seed=0)
    np.testing.assert_array_equal(obs, obs_ref)
    rng = np.random.default_rng(0)
    for _ in range(15):
        a = rng.integers(0, 9, size=4)
        key, sub = jax.random.split(key)
        obs_ref, state, r_ref, term, trunc, info = vstep(jax.random.split(sub, 4), state, a.astype(np.int32), params)
        obs, r, te, tr, vinfo = venv.step(a)
        np.testing.assert_array_equal(obs, obs_ref)
        np.testing.assert_array_equal(r, r_ref)
        np.testing.assert_array_equal(te, term)
        np.testing.assert_array_equal(tr, trunc)
        for i in np.flatnonzero(te | tr):
            np.testing.assert_array_equal(vinfo["final_obs"][i], info["final_observation"][i])
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.array([0, 1]))
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.array([0, 1, 2, 9]))
    with pytest.raises(ValueError, match="num_envs"):
        JaxVectorEnv(dcp, 0, params)


def test_vector_render():
    venv = gymnasium.make_vec(ID, num_envs=4, vectorization_mode="vector_entry_point", render_mode="ansi",
                              grid_size=5)
    venv.reset(seed=0)
    frames = venv.render()
    assert len(frames) == 4 and all(len(f.rstrip("\n").split("\n")) == 6 for f in frames)
    assert all("A" in f for f in frames)


class _PlainEnv(Environment):
    """An environment that writes neither picture hook (``render_ansi``, ``scene``)."""

    def _config(self) -> tuple:
        return ()


class _Shouting(DCP):
    """A DCP variant that names its outcomes differently: the adapters take the names from the env's hook."""

    outcomes = tuple(name.upper() for name in OUTCOMES)


def test_outcome_names_come_from_the_env():
    env = JaxToGymnasium(_Shouting(grid_size=4, total_reward=3), render_mode="ansi")
    env.reset(seed=0)
    _, _, _, _, info = env.step(0)
    assert info["outcome"] in _Shouting.outcomes and info["outcome"].isupper()
    assert env.render().startswith(DCP(grid_size=4, total_reward=3).render_ansi(env.state, env.params)[:1])
    assert JaxToGymnasium(_Shouting(grid_size=4, total_reward=3), outcome_names=OUTCOMES).outcome_names == OUTCOMES
