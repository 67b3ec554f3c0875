"""A heat map of ratios over two axes (maps x budgets): the picture of the generalisation grid (Agg canvas).

:func:`heatmap_png` draws ``values[i][j]`` (``None``: no value) with each cell's
number written in it, on a diverging colour scale centred at ``centre`` (1.0:
as good as the yardstick), and returns PNG bytes; :func:`save_heatmap` writes
them atomically.
"""

from __future__ import annotations

import io
from collections.abc import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure

from jaxdc.io import atomic_write


def heatmap_png(values: Sequence[Sequence[float | None]], rows: Sequence[str], cols: Sequence[str], title: str,
                centre: float = 1.0, label: str = "ratio", marked_cols: Sequence[bool] | None = None) -> bytes:
    """PNG bytes of the heat map; ``marked_cols`` underlines column labels (e.g. budgets inside training)."""
    data = np.array([[np.nan if v is None else float(v) for v in row] for row in values], dtype=np.float64)
    if data.shape != (len(rows), len(cols)):
        raise ValueError(f"values must be {len(rows)} x {len(cols)}, got {data.shape}")
    finite = data[np.isfinite(data)]
    spread = max(0.05, float(np.max(np.abs(finite - centre)))) if finite.size else 0.05
    label_width = 0.065 * max((len(r) for r in rows), default=0)
    fig = Figure(figsize=(2.0 + label_width + 0.9 * len(cols), 1.4 + 0.42 * len(rows)), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    im = ax.imshow(np.ma.masked_invalid(data), cmap="RdYlGn", aspect="auto",
                   norm=TwoSlopeNorm(vcenter=centre, vmin=centre - spread, vmax=centre + spread))
    for i in range(len(rows)):
        for j in range(len(cols)):
            if np.isfinite(data[i, j]):
                ax.text(j, i, f"{data[i, j]:.2f}", ha="center", va="center", fontsize=7)
    ax.set_xticks(range(len(cols)))
    ax.set_xticklabels([f"{c}*" if marked_cols is not None and marked_cols[j] else c for j, c in enumerate(cols)],
                       fontsize=7)
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels(rows, fontsize=7)
    ax.set_title(title, fontsize=8)
    fig.colorbar(im, ax=ax, label=label)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def save_heatmap(path: str, values, rows, cols, title: str, **kwargs) -> str:
    """Write :func:`heatmap_png` to ``path`` atomically; the path."""
    return atomic_write(path, heatmap_png(values, rows, cols, title, **kwargs))
