"""Episodes as pictures: strips of frames (like thesis Figs. 5.13-5.15) and animations.

Both take a Python list of unbatched states (e.g. a rollout's batched states cut
with ``jax.tree_util.tree_map(lambda x: x[i], states)``), render each with
:func:`jaxdc.viewer.render_frame` and write the file atomically
(:func:`jaxdc.io.atomic_write`: a temporary file beside the target, then
``os.replace``), so an interrupted write leaves the previous file or none.
:func:`strip_png` and :func:`animation_bytes` return the same files as bytes,
for a set of files written together (:func:`jaxdc.io.atomic_write_set`).
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

from jaxdc.core.memory import check_fits
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
    """:func:`strip_png` written atomically to ``path`` (which must end in ``.png``); returns the path."""
    if not str(path).lower().endswith(".png"):
        raise ValueError(f"path must end in .png, got {str(path)!r}")
    return atomic_write(path, strip_png(env, params, states, labels=labels, cols=cols))


def strip_png(env, params, states, *, labels=None, cols=None) -> bytes:
    """A PNG strip of frames, ``cols`` per row, like the game strips of Figs. 5.13-5.15, as bytes.

    ``labels`` (one string per state) title the frames; by default each frame is
    titled ``t = <step>``. ``cols`` defaults to ``min(len(states), 8)``. A sheet
    too big for the memory raises ``MemoryError`` before any frame is drawn.
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
    rows = -(-len(states) // cols)
    first = render_frame(env, params, states[0], title=labels[0])
    h, w, _ = first.shape
    check_fits(rows * h * cols * w * 3, f"a strip of {rows} x {cols} frames", "--cols")
    frames = [first] + _frames(env, params, states[1:], labels[1:])
    sheet = np.full((rows * h, cols * w, 3), 255, np.uint8)
    for i, f in enumerate(frames):
        r, c = divmod(i, cols)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = f
    buf = io.BytesIO()
    imsave(buf, sheet, format="png")
    return buf.getvalue()


def save_animation(env, params, states, path, *, fps: int = 4) -> str:
    """An episode as an animation: GIF (``matplotlib.animation`` pillow writer) or MP4 (ffmpeg), by suffix.

    :func:`animation_bytes` written atomically to ``path``. Returns the path written.
    """
    suffix = os.path.splitext(str(path))[1].lower()
    return atomic_write(path, animation_bytes(env, params, states, suffix, fps=fps))


def check_animation(suffix: str, fps) -> str:
    """Validate an animation format (``".gif"``/``".mp4"``) and frame rate (a number in ``(0, 60]``, finite);
    a ``RuntimeError`` if the format's writer is missing. Returns the matplotlib writer's name."""
    if suffix not in ANIMATION_WRITERS:
        raise ValueError(f"path must end in one of {sorted(ANIMATION_WRITERS)}, got {suffix!r}")
    if isinstance(fps, bool) or not isinstance(fps, (int, np.integer, float)) or not 0 < fps <= 60:
        raise ValueError(f"fps must be a number in (0, 60], got {fps!r}")
    writer_name = ANIMATION_WRITERS[suffix]
    if not animation.writers.is_available(writer_name):
        raise RuntimeError(f"saving {suffix} needs the {writer_name!r} matplotlib writer, which is not available: "
                           f"install ffmpeg (e.g. apt-get install ffmpeg) or save a .gif instead")
    return writer_name


def animation_bytes(env, params, states, suffix: str = ".gif", *, fps: int = 4) -> bytes:
    """An episode as the bytes of a GIF (pillow writer) or an MP4 (ffmpeg) file, by ``suffix``.

    One frame per state. MP4 needs ``ffmpeg`` on the PATH; without it a
    ``RuntimeError`` says to install it or to save a ``.gif``.
    """
    states = _check_states(states)
    writer_name = check_animation(suffix, fps)
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
            return f.read()
