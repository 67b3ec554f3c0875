"""The team DCG as text and frames (jaxdc.dcg.team.picture): every collector numbered, every opponent; a
two-collector game through the viewer's GIF path."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc import viewer
from jaxdc.dcg.env import CAUGHT, RUNNING
from jaxdc.dcg.team import DCGTeam
from jaxdc.viewer.frame import AGENT_COLORS, COLORS, cell_center


def _colour(hexcode):
    return np.asarray([int(hexcode[i:i + 2], 16) for i in (1, 3, 5)])


def test_render_ansi_numbers_the_collectors_and_shows_every_opponent():
    env = DCGTeam(collectors=3, opponents=2, strategies=("patrol",))
    params = env.make_params()
    _, s = env.reset(jax.random.PRNGKey(0), params)
    s = s.replace(pos=jnp.asarray([[1, 1], [2, 3], [4, 0]], jnp.int32),
                  collector_outcome=jnp.asarray([RUNNING, RUNNING, CAUGHT], jnp.int32),
                  opponent=s.opponent.replace(pos=jnp.asarray([[3, 3], [0, 4]], jnp.int32)),
                  items=jnp.zeros((5, 5)).at[2, 2].set(3.0))
    rows = env.render_ansi(s, params).splitlines()
    grid = [r.split() for r in rows[:5]]
    assert grid[1][1] == "1" and grid[2][3] == "2" and grid[4][0] == "c"
    assert grid[3][3] == "O" and grid[0][4] == "O" and grid[2][2] == "3" and grid[0][0] == "B"
    assert "1: 15 running" in rows[5] and "3: 15 caught" in rows[5] and "opponents patrol, patrol" in rows[5]


def test_a_two_collector_game_as_frames_and_a_gif(tmp_path):
    env = DCGTeam(collectors=2, strategies=("patrol",))
    params = env.make_params()
    _, s = env.reset(jax.random.PRNGKey(0), params)
    s = s.replace(pos=jnp.asarray([[1, 1], [3, 2]], jnp.int32),
                  opponent=s.opponent.replace(pos=jnp.asarray([[4, 4]], jnp.int32)))
    frame = viewer.render_frame(env, params, s)
    for i, (r, c) in enumerate(((1, 1), (3, 2))):
        y, x = cell_center(5, r, c)
        np.testing.assert_allclose(frame[y + 8, x], _colour(AGENT_COLORS[i]), atol=40)
    y, x = cell_center(5, 4, 4)
    np.testing.assert_allclose(frame[y + 8, x], _colour(COLORS["opponent"]), atol=40)
    states = [s]
    key = jax.random.PRNGKey(1)
    for _ in range(5):
        key, k = jax.random.split(key)
        _, s, *_ = env.step_env(k, s, jnp.asarray([2, 4]), params)
        states.append(s)
    path = viewer.save_animation(env, params, states, tmp_path / "team.gif", fps=4)
    data = open(path, "rb").read()
    assert data[:6] in (b"GIF87a", b"GIF89a") and len(data) > 1000
