"""The chapter-3 line charts (jaxdc.viewer.curves): panels per figure, drawn without pyplot."""

import io
import sys

import pytest

from jaxdc.viewer import draw_curves
from jaxdc.viewer.curves import FIGURE_PANELS

ROWS = [{"clustering": c, "builder": "gi", "alpha": a, "mean": 1.0 - a / 100, "sd": 0.1, "pgc_over_nc": 0.9}
        for c in ("nc", "pgc") for a in (0, 20)]


@pytest.mark.parametrize("figure, panels", [("3.1", 2), ("3.3", 1), ("3.4", 3)])
def test_panels_lines_and_labels(figure, panels):
    pyplot_loaded = "matplotlib.pyplot" in sys.modules
    fig = draw_curves(ROWS, [0, 20], ["gi", "ng"], figure)
    assert len(fig.axes) == panels
    assert tuple(fig.get_size_inches()) == pytest.approx((4.2 * panels, 3.4))
    assert fig._suptitle.get_text() == f"Figure {figure} (ours)"
    for ax, (c, key) in zip(fig.axes, FIGURE_PANELS.get(figure, [("nc", "mean"), ("pgc", "mean"),
                                                                  ("pgc", "pgc_over_nc")])):
        assert [line.get_label() for line in ax.get_lines()] == ["GI", "NG"]
        assert ax.get_xlabel() == "robot value α"
        assert list(ax.get_lines()[0].get_ydata()) == [r[key] for r in ROWS if r["clustering"] == c]
    assert fig.axes[0].get_legend() is not None
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    assert buf.getvalue()[:4] == b"\x89PNG"
    assert ("matplotlib.pyplot" in sys.modules) == pyplot_loaded  # no pyplot state
