"""One grid state as a picture: the DCP (section 4.3) and the DCG (section 5.3).

A frame shows the risk map as a colour field with each cell's value (as in
Fig. 4.1b; the DCG has no risk map and a white field), the base (green cell at
``(0, 0)``), the items as gold discs with their rewards, the agent as a blue
disc with its energy, the DCG opponent as a red disc (a red ring when it shares
the agent's cell, faded while it is hidden from the collector), and, for the
fog strategies of section 5.5.7 (``with_fog``, ``double_blind``), the fog cells
of the top and left edges hatched in grey. A title line (the step by default)
and a status line (energy, reward, outcome, opponent strategy) frame the grid.

The viewer knows no problem: each environment hands it a
:class:`~jaxdc.core.scene.Scene` (:meth:`~jaxdc.core.env.Environment.scene`), the
layers to draw. The layout is fixed in pixels (:data:`CELL_PX` per cell), so that
:func:`cell_center` gives the pixel of any cell's centre.
"""

from __future__ import annotations

from typing import Any

import jax
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import LinearSegmentedColormap, PowerNorm
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Rectangle

from jaxdc.core.env import Environment, writes
from jaxdc.core.scene import Scene

#: Pixels per grid cell (at least; small grids get bigger cells, see :func:`cell_px`), around the
#: grid, above it (title) and below it (status line); the grid is at least MIN_SIDE_PX wide.
CELL_PX, MARGIN_PX, TITLE_PX, STATUS_PX, MIN_SIDE_PX = 48, 8, 26, 22, 384
DPI = 100
#: Colours of the pieces (RGB hex).
COLORS = {"base": "#5cb85c", "item": "#f0c419", "agent": "#1f5fbf", "opponent": "#d62728", "fog": "#9a9a9a",
          "grid": "#c8c8c8"}
#: The colours of the agents of a team (:attr:`Scene.agents`), by index; the first is ``COLORS["agent"]``.
AGENT_COLORS = ("#1f5fbf", "#7b3fa0", "#12867a", "#b8860b")
_RISK_CMAP = LinearSegmentedColormap.from_list("jaxdc_risk", ["#ffffff", "#fdd49e", "#fc8d59", "#b30000"])
_PT = 72.0 / DPI  # points per pixel


def cell_px(grid_size: int) -> int:
    """Pixels per cell of an ``N x N`` grid: :data:`CELL_PX`, more when the grid would be narrower than
    :data:`MIN_SIDE_PX` (room for the status line)."""
    return max(CELL_PX, -(-MIN_SIDE_PX // grid_size))


def frame_size(grid_size: int) -> tuple[int, int]:
    """``(height, width)`` in pixels of a frame of an ``N x N`` grid."""
    side = grid_size * cell_px(grid_size)
    return TITLE_PX + side + STATUS_PX, 2 * MARGIN_PX + side


def cell_center(grid_size: int, row: int, col: int) -> tuple[int, int]:
    """``(y, x)``: the pixel at the centre of cell ``(row, col)`` in a frame of an ``N x N`` grid."""
    cell = cell_px(grid_size)
    return TITLE_PX + int((row + 0.5) * cell), MARGIN_PX + int((col + 0.5) * cell)


def _fmt(x: Any) -> str:
    x = float(x)
    if np.isinf(x):
        return "\u221e"
    return str(int(x)) if x == int(x) else f"{x:.3g}"


def _unbatched_hint() -> str:
    return "pass one unbatched state, e.g. jax.tree_util.tree_map(lambda x: x[i], states)"


def check_frame_input(env: Any, params: Any, state: Any) -> tuple[Any, Any, Scene]:
    """Host copies ``(params, state)`` and their :class:`~jaxdc.core.scene.Scene`, after checking that they belong
    to ``env`` (an environment that writes ``scene``) and are unbatched.

    Raises ``TypeError``/``ValueError`` naming what to pass instead, before any drawing.
    """
    if not isinstance(env, Environment) or not writes(env, "scene"):
        raise TypeError(f"env must be a jaxdc environment that draws its states (a DCP or DCG environment), "
                        f"got {type(env).__name__}")
    name = type(env).__name__
    state_cls, params_cls = env.state_type, env.params_type
    if state_cls is not None and not isinstance(state, state_cls):
        raise TypeError(f"state must be a {name} EnvState ({state_cls.__module__}), got {type(state).__name__}")
    if params_cls is not None and not isinstance(params, params_cls):
        raise TypeError(f"params must be a {name} EnvParams ({params_cls.__module__}; "
                        f"env.make_params(...)), got {type(params).__module__}.{type(params).__name__}")
    params, state = jax.device_get((params, state))
    n = env.grid_size
    want_pos = env.grid_shapes()[1].get("pos", (2,))  # (2,), or (k, 2) for k stacked agents
    items, pos = np.shape(state.items), np.shape(state.pos)
    if len(items) == 3 or len(pos) > len(want_pos):
        raise ValueError(f"state is batched (items {items}, pos {pos}); {_unbatched_hint()}")
    if items != (n, n) or pos != want_pos:
        raise ValueError(f"state has items of shape {items} and pos of shape {pos}, but the env's grid is "
                         f"{n} x {n}: expected items ({n}, {n}) and pos {want_pos}")
    scene = env.scene(state, params)
    cells = [("pos", scene.agent), ("opponent pos", scene.opponent)]
    cells += [("pos", p) for p in (() if scene.agents is None else scene.agents)]
    cells += [("opponent pos", p) for p in (() if scene.opponents is None else scene.opponents)]
    for what, p in cells:
        if p is not None and not all(0 <= int(v) < n for v in np.asarray(p)):
            raise ValueError(f"{what} {tuple(int(v) for v in np.asarray(p))} is outside the {n} x {n} grid")
    if scene.risk is not None and np.shape(scene.risk) != (n, n):
        what = "params are batched" if np.ndim(scene.risk) == 3 else "params do not match the env"
        raise ValueError(f"{what}: risk map of shape {np.shape(scene.risk)}, expected ({n}, {n}); "
                         f"pass the env's unbatched EnvParams (env.make_params(...))")
    return params, state, scene


def _status(scene: Scene) -> str:
    parts = [f"energy {_fmt(scene.energy)}/{_fmt(scene.max_energy)}", f"reward {_fmt(scene.reward)}"]
    parts.extend(scene.notes)
    if scene.outcome != "running":
        parts.append(scene.outcome)
    return "  \u00b7  ".join(parts)


def render_frame(env: Environment, params: Any, state: Any, *, title: str | None = None) -> np.ndarray:
    """One unbatched DCP or DCG state as an RGB picture, ``uint8 [H, W, 3]``.

    Draws the DCP of section 4.3 (risk map with values as in Fig. 4.1b, base,
    agent with its energy, items with their rewards) or the DCG of section 5.3
    (the same plus the opponent, and the fog cells of section 5.5.7 for the
    fog strategies). ``title`` replaces the default ``"<env> step t"``.
    A batched state, a state of another grid size or another environment
    raises ``ValueError``/``TypeError`` saying what to pass.
    """
    if title is not None and not isinstance(title, str):
        raise TypeError(f"title must be a str or None, got {title!r}")
    params, state, scene = check_frame_input(env, params, state)
    n = env.grid_size
    height, width = frame_size(n)
    fig = Figure(figsize=(width / DPI, height / DPI), dpi=DPI, facecolor="white")
    canvas = FigureCanvasAgg(fig)
    cell = cell_px(n)
    side = n * cell
    ax = fig.add_axes((MARGIN_PX / width, STATUS_PX / height, side / width, side / height))
    ax.set_xlim(0, n)
    ax.set_ylim(n, 0)
    ax.set_axis_off()
    small = min(7.0, max(5.0, 0.17 * cell * _PT))
    label = min(11.0, max(6.0, 0.26 * cell * _PT))

    if scene.risk is not None:
        risk = np.asarray(scene.risk, np.float64)
        norm = PowerNorm(0.5, vmin=0.0, vmax=max(float(risk.max()), 1e-9))
        ax.imshow(risk, cmap=_RISK_CMAP, norm=norm, extent=(0, n, n, 0), interpolation="nearest")
        for r in range(n):
            for c in range(n):
                ax.text(c + 0.05, r + 0.05, f"{risk[r, c]:.2g}", ha="left", va="top", fontsize=small,
                        color="white" if norm(risk[r, c]) > 0.75 else "#444444")
    hidden = scene.opponent_hidden
    if scene.fog:
        for r in range(n):
            for c in range(n):
                if (r == 0 or c == 0) and (r, c) != (0, 0):
                    ax.add_patch(Rectangle((c, r), 1, 1, facecolor=COLORS["fog"], alpha=0.55 if hidden else 0.3,
                                           hatch="//", edgecolor="#707070", linewidth=0))
    ax.add_patch(Rectangle((0, 0), 1, 1, facecolor=COLORS["base"], edgecolor="#2d6a2d", linewidth=2, alpha=0.85))
    ax.text(0.95, 0.95, "base", ha="right", va="bottom", fontsize=small, color="#1b401b")
    ax.hlines(np.arange(n + 1), 0, n, colors=COLORS["grid"], linewidth=0.8)
    ax.vlines(np.arange(n + 1), 0, n, colors=COLORS["grid"], linewidth=0.8)

    items = np.asarray(scene.items)
    for r, c in zip(*np.nonzero(items > 0)):
        ax.add_patch(Circle((c + 0.5, r + 0.5), 0.3, facecolor=COLORS["item"], edgecolor="#8a6d00", linewidth=1))
        ax.text(c + 0.5, r + 0.5, _fmt(items[r, c]), ha="center", va="center", fontsize=label, color="black")

    if scene.agents is not None or scene.opponents is not None:
        _draw_team(ax, scene, small, label)
    else:
        _draw_agent_and_opponent(ax, scene, hidden, label)

    if title is None:
        title = f"{type(env).__name__} step {scene.step}"
    fig.text(0.5, 1 - 0.5 * TITLE_PX / height, title, ha="center", va="center", fontsize=9)
    fig.text(0.5, 0.5 * STATUS_PX / height, _status(scene) + (" (opponent hidden)" if hidden else ""),
             ha="center", va="center", fontsize=small + 1)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def _draw_agent_and_opponent(ax: Any, scene: Scene, hidden: bool, label: float) -> None:
    """One agent (blue disc with its energy) and the opponent (red disc, a ring on the agent's cell)."""
    pr, pc = (int(p) for p in np.asarray(scene.agent))
    ax.add_patch(Circle((pc + 0.5, pr + 0.5), 0.36, facecolor=COLORS["agent"], edgecolor="white", linewidth=1.5))
    ax.text(pc + 0.5, pr + 0.5, _fmt(scene.energy), ha="center", va="center", fontsize=label, color="white",
            fontweight="bold")
    if scene.opponent is not None:
        orow, ocol = (int(p) for p in np.asarray(scene.opponent))
        style = {"alpha": 0.35, "linestyle": "--"} if hidden else {}
        if (orow, ocol) == (pr, pc):
            ax.add_patch(Circle((ocol + 0.5, orow + 0.5), 0.44, fill=False, edgecolor=COLORS["opponent"],
                                linewidth=4, **style))
        else:
            ax.add_patch(Circle((ocol + 0.5, orow + 0.5), 0.36, facecolor=COLORS["opponent"], edgecolor="white",
                                linewidth=1.5, **style))
            ax.text(ocol + 0.5, orow + 0.5, "O", ha="center", va="center", fontsize=label, color="white",
                    fontweight="bold", alpha=0.35 if hidden else 1.0)


def _draw_team(ax: Any, scene: Scene, small: float, label: float) -> None:
    """Several agents (:attr:`Scene.agents`), each a disc in its :data:`AGENT_COLORS` colour with its energy and
    its number (faded once disabled; agents sharing a cell are drawn side by side), and every opponent (a red
    disc, or a red ring on an agent's cell)."""
    agents = np.asarray(scene.agent if scene.agents is None else scene.agents).reshape(-1, 2)
    energies = np.asarray([scene.energy] if scene.agent_energies is None else scene.agent_energies).reshape(-1)
    active = np.ones(len(agents), bool) if scene.agents_active is None else np.asarray(scene.agents_active)
    cells = [tuple(int(v) for v in p) for p in agents]
    for i, (r, c) in enumerate(cells):
        share = [j for j, cell in enumerate(cells) if cell == (r, c)]
        rad = 0.36 if len(share) == 1 else 0.22
        dx = 0.0 if len(share) == 1 else (share.index(i) - (len(share) - 1) / 2) * 0.45
        alpha = 1.0 if active[i] else 0.35
        ax.add_patch(Circle((c + 0.5 + dx, r + 0.5), rad, facecolor=AGENT_COLORS[i % len(AGENT_COLORS)],
                            edgecolor="white", linewidth=1.5, alpha=alpha))
        ax.text(c + 0.5 + dx, r + 0.5, _fmt(energies[i]), ha="center", va="center",
                fontsize=label if len(share) == 1 else small, color="white", fontweight="bold", alpha=alpha)
        ax.text(c + 0.5 + dx, r + 0.5 - rad - 0.02, str(i + 1), ha="center", va="bottom", fontsize=small,
                color=AGENT_COLORS[i % len(AGENT_COLORS)], fontweight="bold")
    opponents: Any = [] if scene.opponent is None and scene.opponents is None else \
        np.asarray(scene.opponent if scene.opponents is None else scene.opponents).reshape(-1, 2)
    for r, c in (tuple(int(v) for v in p) for p in opponents):
        if (r, c) in cells:
            ax.add_patch(Circle((c + 0.5, r + 0.5), 0.46, fill=False, edgecolor=COLORS["opponent"], linewidth=4))
        else:
            ax.add_patch(Circle((c + 0.5, r + 0.5), 0.36, facecolor=COLORS["opponent"], edgecolor="white",
                                linewidth=1.5))
            ax.text(c + 0.5, r + 0.5, "O", ha="center", va="center", fontsize=label, color="white",
                    fontweight="bold")
