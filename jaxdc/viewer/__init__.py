"""Pictures of jaxdc states and plans (matplotlib, Agg canvas, no pyplot state).

* :func:`render_frame` -- one DCP (section 4.3) or DCG (section 5.3) state as an
  RGB array: the risk field with its values (Fig. 4.1b), the base, the agent
  with its energy, the items with their rewards, the opponent and the DCG fog.
* :func:`save_strip` -- a PNG strip of frames (like Figs. 5.13-5.15).
* :func:`save_animation` -- an episode as a GIF (pillow) or MP4 (ffmpeg).
* :func:`draw_plan` -- a DRP plan (chapter 3): one coloured tour per robot.

The figures are drawn on their own Agg canvas, never through ``pyplot``, so
rendering leaks no global state and needs no display.
"""

from jaxdc.viewer.curves import draw_curves
from jaxdc.viewer.frame import cell_center, render_frame
from jaxdc.viewer.media import save_animation, save_strip
from jaxdc.viewer.plan import draw_plan

__all__ = ["render_frame", "cell_center", "save_strip", "save_animation", "draw_plan", "draw_curves"]
