"""Episodes as pictures: strips of frames (like thesis Figs. 5.13-5.15) and animations.

Both take a Python list of unbatched states (e.g. a rollout's batched states cut
with ``jax.tree_util.tree_map(lambda x: x[i], states)``), render each with
:func:`jaxdc.viewer.render_frame` and write the file atomically
(:func:`jaxdc.io.atomic_write`).
"""

from __future__ import annotations

import io
import os
import tempfile

import numpy as np
from matplotlib import animation
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.image import imsave

from jaxdc.core.validate import check_positive_int
from jaxdc.io import atomic_write
from jaxdc.viewer.frame import DPI, render_frame

#: Animation formats by file suffix and the matplotlib writer each needs.
ANIMATION_WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}


def _check_states(states) -> list:
    if isinstance(states, (str, bytes)) or not hasattr(states, "__len__"):
        raise TypeError(f"states must be a list of unbatched env states, got {type(states).__name__}")
    states = list(states)
    if not states:
        raise ValueError("states must hold at least one state, got an empty list")
    return states


def _frames(env, params, states, labels) -> list[np.ndarray]:
    return [render_frame(env, params, s, title=lab) for s, lab in zip(states, labels)]


def save_strip(env, params, states, path, *, labels=None, cols=None) -> str:
    """A PNG strip of frames, ``cols`` per row, like the game strips of Figs. 5.13-5.15.

    ``labels`` (one string per state) title the frames; by default each frame is
    titled ``t = <step>``. ``cols`` defaults to ``min(len(states), 8)``.
    Returns the path written.
    """
    states = _check_states(states)
    if labels is None:
        labels = [f"t = {int(np.asarray(s.time))}" if hasattr(s, "time") and np.ndim(s.time) == 0 else None
                  for s in states]
    else:
        labels = [str(lab) for lab in labels]
        if len(labels) != len(states):
            raise ValueError(f"labels must give one label per state ({len(states)}), got {len(labels)}")
    if cols is None:
        cols = min(len(states), 8)
    check_positive_int("cols", cols)
    if not str(path).lower().endswith(".png"):
        raise ValueError(f"path must end in .png, got {str(path)!r}")
    frames = _frames(env, params, states, labels)
    h, w, _ = frames[0].shape
    rows = -(-len(frames) // cols)
    sheet = np.full((rows * h, cols * w, 3), 255, np.uint8)
    for i, f in enumerate(frames):
        r, c = divmod(i, cols)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = f
    buf = io.BytesIO()
    imsave(buf, sheet, format="png")
    return atomic_write(path, buf.getvalue())


def save_animation(env, params, states, path, *, fps: int = 4) -> str:
    """An episode as an animation: GIF (``matplotlib.animation`` pillow writer) or MP4 (ffmpeg), by suffix.

    One frame per state, titled with its step. MP4 needs ``ffmpeg`` on the
    PATH; without it a ``RuntimeError`` says to install it or to save a ``.gif``.
    Returns the path written.
    """
    states = _check_states(states)
    suffix = os.path.splitext(str(path))[1].lower()
    if suffix not in ANIMATION_WRITERS:
        raise ValueError(f"path must end in one of {sorted(ANIMATION_WRITERS)}, got {str(path)!r}")
    if isinstance(fps, bool) or not isinstance(fps, (int, np.integer, float)) or not 0 < fps <= 60:
        raise ValueError(f"fps must be a number in (0, 60], got {fps!r}")
    writer_name = ANIMATION_WRITERS[suffix]
    if not animation.writers.is_available(writer_name):
        raise RuntimeError(f"saving {suffix} needs the {writer_name!r} matplotlib writer, which is not available: "
                           f"install ffmpeg (e.g. apt-get install ffmpeg) or save a .gif instead")
    frames = _frames(env, params, states, [None] * len(states))
    h, w, _ = frames[0].shape
    fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    image = ax.imshow(frames[0], interpolation="nearest")

    def show(i):
        image.set_data(frames[i])
        return (image,)

    anim = animation.FuncAnimation(fig, show, frames=len(frames), interval=1000 / fps, blit=False)
    writer = animation.writers[writer_name](fps=fps)
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "animation" + suffix)
        anim.save(out, writer=writer, dpi=DPI)
        with open(out, "rb") as f:
            data = f.read()
    return atomic_write(path, data)
