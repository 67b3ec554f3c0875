"""The gymnasium adapter of the DCG: jaxdc/DCG-v0, check_env, info, render, vector env, jaxdc.make."""


import gymnasium
import numpy as np
import pytest

import jaxdc
from jaxdc.dcg import DCG
from jaxdc.dcg.env import OUTCOMES

ID = "jaxdc/DCG-v0"


def test_info_and_render():
    env = gymnasium.make(ID, render_mode="ansi", max_steps=5).unwrapped
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    text = env.render()
    assert "C" in text and "O" in text and "energy 15/15" in text
    for t in range(5):
        obs, r, term, trunc, info = env.step(4)
        assert env.observation_space.contains(obs)
        assert info["outcome"] in OUTCOMES and 0 <= info["opponent_action"] < 9
        assert info["strategy"] in (0, 1, 2) and info["episode_steps"] == t + 1
        if term or trunc:
            break
    assert term or trunc


def test_vector_env_and_make():
    venv = gymnasium.make_vec(ID, num_envs=3, vectorization_mode="vector_entry_point", history=2,
                              render_mode="ansi")
    obs, _ = venv.reset(seed=1)
    assert obs.shape == (3, 5, 5, 4)
    obs, r, term, trunc, info = venv.step(np.array([4, 2, 8]))
    assert info["opponent_action"].shape == (3,) and info["strategy"].shape == (3,)
    frames = venv.render()
    assert len(frames) == 3 and all("C" in f for f in frames)
    venv.close()
    env = gymnasium.make(ID, energy=10.0, history=2).unwrapped
    assert env.env == DCG(history=2) and float(env.params.max_energy) == 10.0
    assert ID in gymnasium.registry and "jaxdc/DCP-v0" in gymnasium.registry and jaxdc.__version__


def test_bad_kwargs():
    with pytest.raises(ValueError, match="strategies"):
        gymnasium.make(ID, strategies=("nope",))
    with pytest.raises(ValueError, match="energy"):
        gymnasium.make(ID, energy=0)


def test_rgb_array_render_vector():
    from jaxdc.viewer import cell_center

    venv = gymnasium.make_vec(ID, num_envs=2, vectorization_mode="vector_entry_point", history=2,
                              render_mode="rgb_array")
    venv.reset(seed=2)
    frames = venv.render()
    assert len(frames) == 2 and all(f.dtype == np.uint8 and f.ndim == 3 and f.shape[2] == 3 for f in frames)
    opp = np.asarray(venv.unwrapped.state.opponent.pos)
    for i, frame in enumerate(frames):
        y, x = cell_center(5, *(int(v) for v in opp[i]))
        r, g, b = frame[y + 12, x].astype(int)  # inside the opponent's red disc (the collector starts in the base)
        assert r > g + 80 and r > b + 80
    venv.close()
