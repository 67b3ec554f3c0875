"""jaxdc.viewer: frames checked on the pixels of known cells (no golden images), strips, animations, plans."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc import viewer
from jaxdc.dcg.env import DCG
from jaxdc.dcp.env import DCP
from jaxdc.drp import world
from jaxdc.viewer.frame import cell_px, frame_size
from tests.support.states import make_game, make_state, risk_with

N = 6


def pixel(frame, n, r, c, dy=0.22):
    """The colour a little below the centre of cell (r, c): inside a disc drawn there, clear of its text."""
    y, x = viewer.cell_center(n, r, c)
    return frame[y + int(dy * cell_px(n)), x].astype(int)


@pytest.fixture(scope="module")
def dcp_frame():
    env = DCP(grid_size=N, total_reward=5)
    params = env.make_params(risk=risk_with(N, {(4, 4): 0.9}, fill=0.01), energy=(8.0, 16.0))
    state = make_state(env, pos=(2, 3), energy=7, items={(1, 4): 3})
    return env, params, state, viewer.render_frame(env, params, state)


def test_frame_shape_and_dtype(dcp_frame):
    env, params, state, frame = dcp_frame
    assert frame.dtype == np.uint8
    assert frame.shape == frame_size(N) + (3,)


def test_pieces_have_their_colours(dcp_frame):
    *_, frame = dcp_frame
    empty = pixel(frame, N, 3, 1)
    agent, item, base, high = pixel(frame, N, 2, 3), pixel(frame, N, 1, 4), pixel(frame, N, 0, 0), pixel(frame, N, 4, 4)
    assert empty.min() > 200  # a low-risk empty cell is nearly white
    for other in (agent, item, base, high):
        assert np.abs(other - empty).sum() > 120
    assert agent[2] > agent[0] + 80  # blue
    assert item[0] > 200 and item[1] > 150 and item[2] < 100  # gold
    assert base[1] > base[0] + 40 and base[1] > base[2] + 40  # green
    assert high[0] > high[1] + 80 and high.sum() < empty.sum() - 200  # dark red


def test_risk_colour_grows_with_risk():
    env = DCP(grid_size=N, total_reward=1)
    params = env.make_params(risk=risk_with(N, {(3, 1): 0.2, (3, 3): 0.6}, fill=0.0))
    state = make_state(env, pos=(5, 5), energy=8, items={(5, 4): 1})
    frame = viewer.render_frame(env, params, state, title="risk")
    zero, mid, high = (pixel(frame, N, 3, c).sum() for c in (5, 1, 3))
    assert zero > mid + 60 > high + 120


def test_dcg_opponent_and_fog():
    env = DCG(grid_size=5, strategies=("patrol", "with_fog", "double_blind"), history=2)
    params = env.make_params()
    n = env.grid_size
    frames = {s: viewer.render_frame(env, params, make_game(env, pos=(2, 2), opp=(3, 4), strategy=s))
              for s in ("patrol", "with_fog")}
    opp = pixel(frames["patrol"], n, 3, 4)
    assert opp[0] > opp[2] + 80 and opp[0] > opp[1] + 80  # red
    fog_cell, open_cell = (0, 3), (2, 4)
    assert np.abs(pixel(frames["patrol"], n, *fog_cell) - pixel(frames["patrol"], n, *open_cell)).sum() < 10
    assert pixel(frames["with_fog"], n, *fog_cell).sum() < pixel(frames["with_fog"], n, *open_cell).sum() - 60
    # double-blind: the collector in the fog does not see the opponent, which is drawn faded
    seen = viewer.render_frame(env, params, make_game(env, pos=(2, 2), opp=(3, 4), strategy="double_blind"))
    hidden = viewer.render_frame(env, params, make_game(env, pos=(0, 2), opp=(3, 4), strategy="double_blind"))
    assert pixel(hidden, n, 3, 4).sum() > pixel(seen, n, 3, 4).sum() + 150


def test_bad_input_says_what_to_pass():
    env = DCP(grid_size=N, total_reward=5)
    params = env.make_params()
    one = make_state(env, pos=(1, 1), energy=5, items={(2, 2): 1})
    batched = jax.tree_util.tree_map(lambda x: jnp.stack([x, x, x]), one)
    with pytest.raises(ValueError, match="batched.*tree_map"):
        viewer.render_frame(env, params, batched)
    small = make_state(DCP(grid_size=4, total_reward=5), pos=(1, 1), energy=5, items={(2, 2): 1})
    with pytest.raises(ValueError, match=r"grid is 6 x 6"):
        viewer.render_frame(env, params, small)
    with pytest.raises(ValueError, match=r"pos \(1, 6\) is outside"):
        viewer.render_frame(env, params, one.replace(pos=jnp.array([1, 6], jnp.int32)))
    stacked = jax.tree_util.tree_map(lambda x: jnp.stack([x, x]), params)
    with pytest.raises(ValueError, match="params are batched"):
        viewer.render_frame(env, stacked, one)
    game = DCG(grid_size=N, history=2)
    with pytest.raises(TypeError, match="DCP EnvState"):
        viewer.render_frame(env, params, make_game(game, pos=(0, 0), opp=(2, 2), strategy="patrol"))
    with pytest.raises(TypeError, match="env must be"):
        viewer.render_frame("DCP", params, one)


def _episode(env, steps):
    """The agent walking along the bottom row towards an item in the corner."""
    n = env.grid_size
    return [make_state(env, pos=(n - 1, t), energy=8 - t, items={(n - 1, n - 1): 2}, time=t) for t in range(steps + 1)]


def test_strip_and_animation(tmp_path, monkeypatch):
    from matplotlib import animation
    from matplotlib.image import imread
    from PIL import Image

    env = DCP(grid_size=4, total_reward=3)
    params = env.make_params(risk="low")
    states = _episode(env, 3)
    path = viewer.save_strip(env, params, states, tmp_path / "strip.png", cols=3)
    h, w = frame_size(4)
    assert imread(path).shape[:2] == (2 * h, 3 * w)
    with pytest.raises(ValueError, match="one label per state"):
        viewer.save_strip(env, params, states, tmp_path / "s.png", labels=["a"])
    gif = viewer.save_animation(env, params, states, tmp_path / "ep.gif", fps=5)
    with Image.open(gif) as im:
        assert im.n_frames == len(states) and im.size == (w, h)
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".tmp")]
    with pytest.raises(ValueError, match=r"\.gif"):
        viewer.save_animation(env, params, states, tmp_path / "ep.avi")
    monkeypatch.setattr(animation.writers, "is_available", lambda name: False)
    with pytest.raises(RuntimeError, match="install ffmpeg"):
        viewer.save_animation(env, params, states, tmp_path / "ep.mp4")


def test_draw_plan_one_colour_per_robot():
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_hex

    before = plt.get_fignums()
    graph = world.generate(0, n=8, size=40.0)
    tours = [[1, 2, 3], [4, 5], [6]]
    fig = viewer.draw_plan(graph, tours)
    lines = fig.axes[0].get_lines()
    assert len(lines) == 3
    colours = {to_hex(ln.get_color()) for ln in lines}
    assert len(colours) == 3
    for ln, tour in zip(lines, tours):  # closed tour: base, the nodes, base
        xy = np.asarray(ln.get_xydata())
        assert np.allclose(xy[0], graph.base) and np.allclose(xy[-1], graph.base)
        assert np.allclose(xy[1:-1], graph.nodes[np.asarray(tour) - 1])
    padded = np.array([[1, 2, 3], [4, 5, -1], [6, -1, -1]])
    same = viewer.draw_plan(graph, {"tours": padded})
    assert same.axes[0].get_title() == fig.axes[0].get_title()
    assert plt.get_fignums() == before  # no pyplot figure leaked
    with pytest.raises(ValueError, match=r"outside 1\.\.8"):
        viewer.draw_plan(graph, [[0, 1]])
    with pytest.raises(TypeError, match="Graph"):
        viewer.draw_plan({"nodes": []}, tours)


class _Watched(DCP):
    """A DCP variant whose scene adds an opponent at ``spot``: the viewer draws what the env's hook says, whatever
    the env's type."""

    spot = (4, 1)

    def scene(self, state, params):
        return dataclasses.replace(super().scene(state, params), opponent=np.array(self.spot), notes=("watched",))


class _Off(_Watched):
    spot = (7, 1)


def test_viewer_draws_the_env_scene_hook():
    env = _Watched(grid_size=N, total_reward=5)
    params = env.make_params(risk=risk_with(N, {}, fill=0.0))
    state = make_state(env, pos=(2, 3), energy=7, items={(1, 4): 3})
    frame = viewer.render_frame(env, params, state)
    plain = viewer.render_frame(DCP(grid_size=N, total_reward=5), params, state)
    opp = pixel(frame, N, 4, 1)
    assert opp[0] > opp[2] + 80 and pixel(plain, N, 4, 1).min() > 200  # red only where the hook put the opponent
    with pytest.raises(ValueError, match=r"opponent pos \(7, 1\) is outside"):
        viewer.render_frame(_Off(grid_size=N, total_reward=5), params, state)
