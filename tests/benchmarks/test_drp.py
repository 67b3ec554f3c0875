"""benchmarks/drp.py: every printed result records its provenance (an object gains the key, rows are wrapped)."""

from __future__ import annotations

import json

import jaxdc
from benchmarks import drp as bench


def _printed(capsys, argv):
    assert bench.main(argv) in (0, None)
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])


def test_rows_are_printed_with_their_provenance(capsys):
    out = _printed(capsys, ["--nc-cache", "--cc-graphs", "1", "--cc-nodes", "6", "--cc-alphas", "0",
                            "--cc-builders", "ng", "--cc-rounds", "cached", "--json"])
    assert set(out) == {"rows", "provenance"}
    assert out["rows"][0]["builder"] == "ng" and out["rows"][0]["identical_clusters"] is True
    assert out["provenance"]["jaxdc_version"] == jaxdc.__version__
    assert "--nc-cache" in out["provenance"]["command"]


def test_an_object_gains_the_provenance_key(capsys):
    out = _printed(capsys, ["--gi-resume-stats", "--nodes", "8", "--alpha", "20"])
    assert out["jobs"] > 0 and 0 <= out["share_skipped"] <= 1
    assert set(out["provenance"]) >= {"jaxdc_version", "jax_version", "git", "device", "command"}
    assert "--gi-resume-stats" in out["provenance"]["command"]
