"""A DRP plan (thesis chapter 3) drawn as coloured tours on the node map."""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from jaxdc.drp import world as drp_world

__all__ = ["draw_plan", "plan_tours"]


def plan_tours(plan, n: int) -> list[list[int]]:
    """The tours of ``plan`` as lists of node indices (1..n) after checking them.

    ``plan`` is a list of tours (node lists, as ``eval.drp plan`` prints and
    :func:`jaxdc.drp.plans.plan_tours` returns), a ``[T, L]`` array padded
    with ``-1`` (section 3.3's plan), or a dict with a ``"tours"`` entry.
    """
    if isinstance(plan, dict):
        if "tours" not in plan:
            raise ValueError(f"a plan dict must have a 'tours' entry, got keys {sorted(plan)}")
        plan = plan["tours"]
    if isinstance(plan, np.ndarray) or hasattr(plan, "__array__"):
        arr = np.asarray(plan)
        if arr.ndim == 1:
            arr = arr[None]
        if arr.ndim != 2:
            raise ValueError(f"a plan array must be [T, L] (one row per robot), got shape {arr.shape}")
        plan = [[int(v) for v in row if v >= 0] for row in arr]
    tours = []
    for i, tour in enumerate(plan):
        try:
            tour = [int(v) for v in tour]
        except (TypeError, ValueError):
            raise TypeError(f"tour {i} must be a list of node indices, got {tour!r}") from None
        bad = [v for v in tour if not 1 <= v <= n]
        if bad:
            raise ValueError(f"tour {i} visits nodes {bad} outside 1..{n} (node 0 is the base, left implicit)")
        tours.append(tour)
    return tours


def draw_plan(world, plan, *, ax=None, title: str | None = None):
    """Draw a DRP plan: node map (marker size by reward), base, one coloured closed tour per robot.

    ``world`` is a :class:`jaxdc.drp.world.Graph` (section 3.3); ``plan`` as in
    :func:`plan_tours`. The default title gives the number of robots and the
    plan's expected reward (Eq. 3.1). Draws into ``ax`` when given, else on a
    new pyplot-free figure. Returns the matplotlib ``Figure``. The graph is checked first
    (:func:`jaxdc.drp.world.validate`).
    """
    if not isinstance(world, drp_world.Graph):
        raise TypeError(f"world must be a jaxdc.drp.world.Graph (e.g. world.generate(...) or world.load(path)), "
                        f"got {type(world).__name__}")
    world = drp_world.validate(world)  # finite, float32-safe coordinates and rewards (ValueError names the field)
    nodes = np.asarray(world.nodes, np.float64)
    n = len(nodes)
    tours = plan_tours(plan, n)
    if ax is None:
        fig = Figure(figsize=(5.0, 5.0), dpi=100)
        FigureCanvasAgg(fig)
        ax = fig.add_subplot()
    fig = ax.figure
    base = np.asarray(world.base, np.float64)
    rewards = np.asarray(world.rewards, np.float64)
    visited = np.zeros(n, bool)
    colors = _tour_colors(len(tours))
    for i, tour in enumerate(tours):
        idx = np.asarray(tour, int) - 1
        visited[idx] = True
        pts = np.vstack([base, nodes[idx], base])
        ax.plot(pts[:, 0], pts[:, 1], "-", color=colors[i], linewidth=1.6, alpha=0.9, label=f"robot {i + 1}")
        ax.scatter(nodes[idx, 0], nodes[idx, 1], s=12 + 6 * rewards[idx], color=colors[i], edgecolors="black",
                   linewidths=0.4, zorder=3)
    rest = ~visited
    ax.scatter(nodes[rest, 0], nodes[rest, 1], s=12 + 6 * rewards[rest], facecolors="none", edgecolors="#888888",
               linewidths=0.8, zorder=2, label="not visited" if rest.any() else None)
    ax.scatter([base[0]], [base[1]], marker="s", s=90, color="black", zorder=4, label="base")
    if title is None:
        padded = np.full((max(len(tours), 1), max([len(t) for t in tours] + [1])), -1, np.int32)
        for i, t in enumerate(tours):
            padded[i, :len(t)] = t
        D, beta, psi = drp_world.arrays(world)
        value = float(drp_world.expected_reward(D, beta, psi, padded)) if tours else 0.0
        title = f"{len(tours)} robot(s), expected reward {value:.2f} (alpha {world.alpha:g}, psi {world.psi:g})"
    ax.set_title(title, fontsize=9)
    ax.set_aspect("equal")
    ax.legend(fontsize=7, loc="best", framealpha=0.8)
    return fig


def _tour_colors(count: int) -> list:
    """``count`` distinct colours (tab10, then tab20, then a hue wheel)."""
    from matplotlib import colormaps

    if count <= 10:
        return [colormaps["tab10"](i) for i in range(count)]
    if count <= 20:
        return [colormaps["tab20"](i) for i in range(count)]
    return [colormaps["hsv"](i / count) for i in range(count)]


