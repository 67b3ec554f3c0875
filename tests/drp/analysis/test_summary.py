"""The section 3.5 summaries: normalisation, PGC / NC, markdown tables, CSV and the stored record."""

import numpy as np
import pytest

from jaxdc.drp.analysis.summary import ROW_FIELDS, experiment_record, markdown_tables, rows_csv, summarise

RAW = {("nc", "gi"): np.array([[10.0, 5.0], [30.0, 5.0]]), ("pgc", "gi"): np.array([[10.0, 2.0], [30.0, 3.0]])}


def test_summarise_normalises_by_alpha_zero():
    norm, rows = summarise(RAW, [0, 20])
    assert norm == 20.0
    r = {(x["clustering"], x["alpha"]): x for x in rows}
    assert r[("nc", 20)]["mean"] == 0.25 and r[("nc", 0)]["sd"] == 0.5
    assert r[("pgc", 20)]["pgc_over_nc"] == pytest.approx(0.5)
    md = markdown_tables(rows, [20], ["gi"]).splitlines()
    assert md[0] == "| NC mean (SD) | α=20 |" and md[2] == "| GI | 0.250 (0.000) |"
    assert "| GI | 0.125 (0.025) |" in md and md[-1] == "| GI | 0.50 |"


def test_rows_csv_and_record():
    _, rows = summarise(RAW, [0, 20])
    lines = rows_csv(rows).splitlines()
    assert lines[0] == ",".join(ROW_FIELDS) and len(lines) == 1 + len(rows)
    assert lines[1] == "nc,gi,0,1.0,0.5,"
    rec = experiment_record({"graphs": 2}, RAW, {"nc_gi": 1.5}, 3.0, [0, 20])
    assert list(rec) == ["config", "wall_seconds", "timing", "normaliser", "rows", "raw"]
    assert rec["raw"] == {"nc_gi": [[10.0, 5.0], [30.0, 5.0]], "pgc_gi": [[10.0, 2.0], [30.0, 3.0]]}
    assert rec["rows"] == rows and rec["normaliser"] == 20.0
