"""Hostile input for jaxdc.drp.analysis.summary: an undefined normaliser never yields NaN.
"""


import numpy as np

from jaxdc.drp.analysis.summary import rows_csv, summarise


def test_summarise_never_yields_nan():
    raw = {("nc", "gi"): np.zeros((3, 2)), ("pgc", "gi"): np.zeros((3, 2))}
    norm, rows = summarise(raw, [0, 10])
    assert norm is None and all(r["mean"] is None for r in rows)
    assert all(r["pgc_over_nc"] is None for r in rows if r["clustering"] == "pgc")
    assert ",," in rows_csv(rows)  # an undefined statistic is an empty cell
