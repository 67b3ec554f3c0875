"""Hostile input for jaxdc.viewer.media: animation rates are validated and a refused animation leaves no file.
"""

from __future__ import annotations

import os

import jax
import pytest

from jaxdc.dcg.env import DCG
from jaxdc.viewer import media


# -- media: atomic, validated --------------------------------------------------------------------------
@pytest.mark.parametrize("fps", [0, float("inf"), float("nan"), True, 61])
def test_animation_fps_refused(fps):
    with pytest.raises(ValueError, match="fps"):
        media.check_animation(".gif", fps)


def test_animation_refused_leaves_no_file(tmp_path):
    env = DCG(grid_size=3, total_reward=2, history=1, obs_history=False)
    params = env.make_params(energy=5.0, max_steps=5)
    _, state = env.reset_env(jax.random.PRNGKey(0), params)
    with pytest.raises(ValueError, match="fps"):
        media.save_animation(env, params, [state], tmp_path / "a.gif", fps=float("nan"))
    with pytest.raises(ValueError, match="path must end"):
        media.save_animation(env, params, [state], tmp_path / "a.avi")
    assert os.listdir(tmp_path) == []
