"""Hostile input for the results page command line (eval.report, jaxdc.cli.eval_report).

Every bad value is refused before any work with a non-zero exit and one line naming the flag (or the file and
key), the value and the allowed range, without a traceback; no NaN or Infinity reaches a file or stdout; an
interruption leaves the old files or the complete new set.
"""

from __future__ import annotations

import json

import pytest

from jaxdc.cli import eval_report as report
from tests.support.cli_checks import refused

_refused = refused


# ----------------------------------------------------------------------------- eval.report


def _table(tmp_path, text):
    d = tmp_path / "results" / "dcp"
    d.mkdir(parents=True, exist_ok=True)
    (d / "table_4.8.json").write_text(text)
    return str(tmp_path / "results")


GOOD = json.dumps({"table": "4.8", "caption": "c", "command": "python -m eval.dcp --table 4.8", "thesis": {},
                   "ours": {"p": {"reward": {"mean": 1.0, "sd": 0.0}, "energy": {"mean": 0.0, "sd": 0.0},
                                  "rpe": {"mean": None, "sd": None, "undefined": "no episode consumed energy"},
                                  "episodes": 5}}})


def test_report_missing_notes_refused(tmp_path, capsys):
    res = _table(tmp_path, GOOD)
    out = tmp_path / "page.md"
    _refused(report.main, ["--results", res, "--out", str(out), "--notes", str(tmp_path / "missing.md")], capsys,
             "--notes", "missing.md")
    assert not out.exists()


@pytest.mark.parametrize("where, needles", [("file/page.md", ("--out", "is a file")), ("", ("--out", "folder"))])
def test_report_out_checked_first(tmp_path, capsys, where, needles):
    res = _table(tmp_path, GOOD)
    (tmp_path / "file").write_text("x")
    _refused(report.main, ["--results", res, "--out", str(tmp_path / where), "--notes", "none"], capsys, *needles)
    assert (tmp_path / "file").read_text() == "x"


@pytest.mark.parametrize("text, needles", [
    ('{"table": "4.8", "ours": {"p": {"reward": {"mean": NaN}}}}', ("table_4.8.json", "NaN")),
    ('{"table": "4.8", "ours": {"p": {"reward": {"mean": Infinity}}}}', ("table_4.8.json", "Infinity")),
    ('{"table": "4.8", ', ("table_4.8.json", "not valid JSON")),
    ('{"table": "4.8"}', ("table_4.8.json", "caption is missing", "rerun python -m eval.dcp --table")),
])
def test_report_damaged_table_refused(tmp_path, capsys, text, needles):
    res = _table(tmp_path, text)
    out = tmp_path / "page.md"
    _refused(report.main, ["--results", res, "--out", str(out), "--notes", "none"], capsys, *needles)
    assert not out.exists()


def test_report_results_is_a_file(tmp_path, capsys):
    (tmp_path / "r").write_text("x")
    _refused(report.main, ["--results", str(tmp_path / "r"), "--out", str(tmp_path / "p.md")], capsys, "--results")


def test_report_undefined_rpe_is_a_dash(tmp_path, capsys):
    res = _table(tmp_path, GOOD)
    out = tmp_path / "page.md"
    assert report.main(["--results", res, "--out", str(out), "--notes", "none"]) == 0
    page = out.read_text()
    assert "| p | — | 1.00 ± 0.00 | — | — | 0.00 ± 0.00 | — | — |" in page and "nan" not in page.lower()


# ----------------------------------------------------------------------------- an output that is an input


@pytest.mark.parametrize("link", [False, True])
def test_report_out_that_is_the_notes_refused(tmp_path, capsys, link):
    """`--notes N.md --out N.md` (or --out a symbolic link to N.md) would replace the notes with the page."""
    res = _table(tmp_path, GOOD)
    notes = tmp_path / "N.md"
    notes.write_text("my notes\n")
    out = notes
    if link:
        out = tmp_path / "page.md"
        out.symlink_to(notes)
    _refused(report.main, ["--results", res, "--notes", str(notes), "--out", str(out)], capsys,
             "would overwrite the input --notes", "N.md")
    assert notes.read_text() == "my notes\n"


def test_report_out_inside_the_results_refused(tmp_path, capsys):
    """The page written into the results folder it reads would be read back by the next run."""
    res = _table(tmp_path, GOOD)
    _refused(report.main, ["--results", res, "--notes", "none", "--out", res + "/page.md"], capsys,
             "would overwrite the input --results")
