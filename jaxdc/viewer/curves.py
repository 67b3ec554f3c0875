"""The chapter-3 figures' line charts (Figs. 3.1-3.5): normalised reward, SD and PGC / NC against alpha."""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ["draw_curves", "FIGURE_PANELS"]

#: The panels of each figure, ``(clustering, row key)``; any other figure gets NC mean, PGC mean and PGC / NC.
FIGURE_PANELS = {"3.1": [("nc", "mean"), ("nc", "sd")], "3.2": [("pgc", "mean"), ("pgc", "sd")],
                 "3.3": [("pgc", "pgc_over_nc")]}
_DEFAULT_PANELS = [("nc", "mean"), ("pgc", "mean"), ("pgc", "pgc_over_nc")]
_LABELS = {"mean": "normalised mean reward", "sd": "normalised SD", "pgc_over_nc": "PGC / NC"}


def draw_curves(rows, alphas, builders, figure: str) -> Figure:
    """Figure ``figure`` (``"3.1"`` .. ``"3.5"``) of section 3.5 from the experiment's summary rows.

    ``rows`` are :func:`jaxdc.drp.analysis.summary.summarise`'s; one line per builder
    over ``alphas`` in each panel (:data:`FIGURE_PANELS`), missing points left
    out. Drawn on its own Agg canvas (no pyplot state); returns the ``Figure``.
    """
    panels = FIGURE_PANELS.get(figure, _DEFAULT_PANELS)
    fig = Figure(figsize=(4.2 * len(panels), 3.4))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(panels), squeeze=False)
    for ax, (c, key) in zip(axes[0], panels):
        for b in builders:
            ys = [next((r[key] for r in rows if r["clustering"] == c and r["builder"] == b and r["alpha"] == a),
                       None) for a in alphas]
            ys = [np.nan if y is None else y for y in ys]
            ax.plot(alphas, ys, marker="o", ms=3, label=b.upper())
        ax.set_xlabel("robot value α")
        ax.set_ylabel(_LABELS[key])
        ax.set_title(f"{'PGC' if c == 'pgc' else 'NC'}: {_LABELS[key]}" if key != "pgc_over_nc" else "PGC / NC")
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.suptitle(f"Figure {figure} (ours)")
    fig.tight_layout()
    return fig
