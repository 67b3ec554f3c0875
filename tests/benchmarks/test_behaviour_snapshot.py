"""benchmarks/behaviour_snapshot.py: a recorded case carries the recording's provenance, which compare ignores."""

from __future__ import annotations

import json
import sys

import jaxdc
from benchmarks import behaviour_snapshot as snap


def test_record_stores_provenance_and_compare_ignores_it(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(snap, "cases", lambda: {"echo": [[sys.executable, "-c", "print('{\"x\": 1}')"]]})
    for d in ("before", "after"):
        assert snap.record(str(tmp_path / d)) == 0
    with open(tmp_path / "before" / "echo.json") as f:
        case = json.load(f)
    assert case["steps"][0]["stdout"] == [{"x": 1}] and case["steps"][0]["rc"] == 0
    assert case["provenance"]["jaxdc_version"] == jaxdc.__version__
    assert case["provenance"]["command"].endswith(f"record {tmp_path / 'before'}")
    assert snap.compare(str(tmp_path / "before"), str(tmp_path / "after")) == 0  # provenance differs: ignored
    case["steps"][0]["stdout"] = [{"x": 2}]
    (tmp_path / "after" / "echo.json").write_text(json.dumps(case))
    capsys.readouterr()
    assert snap.compare(str(tmp_path / "before"), str(tmp_path / "after")) == 1
    assert "/steps[0]/stdout[0]/x: 1 != 2" in capsys.readouterr().out
