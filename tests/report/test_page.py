"""The results page (jaxdc.report) and its CLI (jaxdc.cli.eval_report): the page from results JSON, and a clear
error without results."""

import json

import pytest

from jaxdc.cli import eval_report as report
from jaxdc.report import build_page
from jaxdc.report.copied import _relink
from jaxdc.report.dcp_tables import dcp_table


def test_report_builds_page_with_commands_and_se(tmp_path):
    d = tmp_path / "results" / "dcp"
    d.mkdir(parents=True)
    payload = {"table": "4.8", "caption": "one item", "command": "python -m eval.dcp --table 4.8",
               "thesis": {"safe_neither": [0.55, 0.50, 4.78, 3.68, 0.228, 0.317]},
               "ours": {"safe_neither": {"reward": {"mean": 0.56, "sd": 0.5}, "energy": {"mean": 4.8, "sd": 3.7},
                                         "rpe": {"mean": 0.23, "sd": 0.3}, "episodes": 10000}}}
    (d / "table_4.8.json").write_text(json.dumps(payload))
    out = tmp_path / "results.md"
    assert report.main(["--results", str(tmp_path / "results"), "--out", str(out), "--notes", "none"]) == 0
    page = out.read_text()
    assert "`python -m eval.dcp --table 4.8`" in page
    assert "| safe_neither | 0.55 ± 0.50 | 0.56 ± 0.50 | +2.0 |" in page  # (0.56-0.55)/(0.5/100)


def test_report_without_results_says_what_to_run(tmp_path, capsys):
    (tmp_path / "results").mkdir()  # empty; the page goes outside it (an output inside an input folder is refused)
    assert report.main(["--results", str(tmp_path / "results"), "--out", str(tmp_path / "r.md")]) == 2
    assert "python -m eval.dcp --table" in capsys.readouterr().err
    assert not (tmp_path / "r.md").exists()


def test_report_shows_learned_row_source_and_incr(tmp_path):
    d = tmp_path / "results" / "dcp"
    d.mkdir(parents=True)
    row = {"reward": {"mean": 13.0, "sd": 7.0}, "energy": {"mean": 24.0, "sd": 17.0},
           "rpe": {"mean": 0.68, "sd": 0.31}, "episodes": 10000}
    payload = {"table": "4.3", "caption": "high risk", "command": "python -m eval.dcp --table 4.3",
               "thesis": {"enn": [13.16, 7.17, 23.87, 16.88, 0.685, 0.314]}, "ours": {"enn": row},
               "learned": {"net": "enn", "source": "jaxdc/assets/dcp/enn.msgpack",
                           "command": "python -m train.dcp --net enn"},
               "incr": {"safe_reward": {"reward": [13.94, 12.5], "energy": [-19.49, None], "rpe": [38.38, 40.0]}}}
    (d / "table_4.3.json").write_text(json.dumps(payload))
    out = tmp_path / "results.md"
    assert report.main(["--results", str(tmp_path / "results"), "--out", str(out), "--notes", "none"]) == 0
    page = out.read_text()
    assert "| enn | 13.16 ± 7.17 | 13.00 ± 7.00 | -2.2 |" in page  # (13.00-13.16)/(7.17/100)
    assert "Learned row `enn`: parameters `jaxdc/assets/dcp/enn.msgpack`, trained by `python -m train.dcp --net enn`" \
        in page
    assert "| safe_reward | 13.94 | 12.50 | -19.49 | — | 38.38 | 40.00 |" in page


def _results_with_one_dcp_table(tmp_path):
    """A results folder holding only an empty Table 4.8 (the page needs some DCP result)."""
    res = tmp_path / "results"
    (res / "dcp").mkdir(parents=True)
    (res / "dcp" / "table_4.8.json").write_text(json.dumps(
        {"table": "4.8", "caption": "c", "command": "python -m eval.dcp --table 4.8", "thesis": {}, "ours": {}}))
    return res


def test_report_copies_dcg_figures_and_benchmarks_with_links_fixed(tmp_path):
    res = _results_with_one_dcp_table(tmp_path)
    (res / "dcg").mkdir()
    (res / "dcg" / "figure_standard.md").write_text(
        "### Fig 5.6\n\n`python -m eval.dcg figure all`\n\n![f](../../docs/img/dcg_fig5_6.png)\n")
    (res / "benchmarks" / "t16").mkdir(parents=True)
    (res / "benchmarks" / "t16" / "train_throughput.md").write_text("`python benchmarks/train_throughput.py`\n| a |\n")
    docs = tmp_path / "docs"
    assert report.main(["--results", str(res), "--out", str(docs / "results.md"), "--notes", "none"]) == 0
    page = (docs / "results.md").read_text()
    assert "## DCG (chapter 5)" in page and "`python -m eval.dcg figure all`" in page
    assert "![f](img/dcg_fig5_6.png)" in page  # relative to docs/, where the page lives
    assert "`python benchmarks/train_throughput.py`" in page
    assert "[drp.md](drp.md)" in page


def test_report_says_what_to_run_for_missing_sections(tmp_path):
    res = _results_with_one_dcp_table(tmp_path)
    out = tmp_path / "r.md"
    assert report.main(["--results", str(res), "--out", str(out), "--notes", "none"]) == 0
    assert "No results yet: run `python -m eval.dcg figure all`" in out.read_text()


def test_the_notes_on_the_results_page_are_the_notes_file():
    """docs/results.md is hand-edited between regenerations; its notes must stay those of docs/results_notes.md,
    which ``eval.report`` inserts, so that a regeneration keeps them."""
    import pathlib

    docs = pathlib.Path(__file__).resolve().parents[2] / "docs"
    notes = (docs / "results_notes.md").read_text().strip()
    assert notes.startswith("## ") and notes in (docs / "results.md").read_text()


def test_build_page_needs_a_dcp_table(tmp_path):
    with pytest.raises(FileNotFoundError, match="python -m eval.dcp --table 4.3"):
        build_page(str(tmp_path), None)


def test_build_page_orders_tables_numerically_and_inserts_notes(tmp_path):
    res = tmp_path / "results"
    (res / "dcp").mkdir(parents=True)
    for t in ("4.10", "4.3", "4.9"):
        (res / "dcp" / f"table_{t}.json").write_text(json.dumps(
            {"table": t, "caption": "c", "command": f"python -m eval.dcp --table {t}", "thesis": {}, "ours": {}}))
    notes = tmp_path / "notes.md"
    notes.write_text("## My notes\n")
    page = build_page(str(res), str(notes), str(tmp_path))
    assert page.index("Table 4.3:") < page.index("Table 4.9:") < page.index("Table 4.10:") < page.index("## My notes")
    assert dcp_table(json.loads((res / "dcp" / "table_4.3.json").read_text())) in page


def test_relink_keeps_urls_and_anchors(tmp_path):
    text = "![a](../img/x.png) [b](http://h/p) [c](#top) [d](/abs)"
    got = _relink(text, str(tmp_path / "results" / "dcg" / "f.md"), str(tmp_path / "results"))
    assert got == "![a](img/x.png) [b](http://h/p) [c](#top) [d](/abs)"


def test_eval_report_shim_is_the_cli():
    from eval import report as shim

    assert shim.main is report.main and shim.build_parser is report.build_parser


def test_report_shows_best_row_against_the_thesis_learned_row(tmp_path):
    d = tmp_path / "results" / "dcp"
    d.mkdir(parents=True)
    row = {"reward": {"mean": 13.0, "sd": 7.0}, "energy": {"mean": 24.0, "sd": 17.0},
           "rpe": {"mean": 0.68, "sd": 0.31}, "episodes": 10000}
    best = dict(row, reward={"mean": 14.8, "sd": 7.0})
    payload = {"table": "4.3", "caption": "high risk", "command": "python -m eval.dcp --table 4.3",
               "thesis": {"enn": [13.16, 7.17, 23.87, 16.88, 0.685, 0.314]}, "ours": {"enn": row, "enn best": best},
               "learned": {"net": "enn", "row": "enn", "source": "enn"},
               "best": {"row": "enn best", "thesis_row": "enn", "checkpoint": "enn_long", "source": "enn_long",
                        "differs": "16M steps", "trained": {}}}
    (d / "table_4.3.json").write_text(json.dumps(payload))
    out = tmp_path / "results.md"
    assert report.main(["--results", str(tmp_path / "results"), "--out", str(out), "--notes", "none"]) == 0
    page = out.read_text()
    assert "| enn best: enn_long | 13.16 ± 7.17 | 14.80 ± 7.00 | +22.9 |" in page  # (14.80-13.16)/(7.17/100)
    assert "the best shipped jaxdc learner for this table, `enn_long` (16M steps)" in page


def test_committed_page_is_rebuilt_from_the_committed_results():
    """docs/results.md is exactly what `python -m eval.report` builds from results/ and the notes (all committed)."""
    import os

    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    docs = os.path.join(root, "docs")
    page = build_page(os.path.join(root, "results"), os.path.join(docs, "results_notes.md"), docs,
                      os.path.join(docs, "results_notes_dcg.md"))
    with open(os.path.join(docs, "results.md")) as f:
        committed = f.read()
    assert page == committed, "docs/results.md is stale: run `python -m eval.report` and commit the page"


# -- hostile input (issue 31) ---------------------------------------------------------------------------------
def test_a_damaged_table_is_refused_with_one_line_naming_file_and_key(tmp_path, capsys):
    res = _results_with_one_dcp_table(tmp_path)
    path = res / "dcp" / "table_4.8.json"
    rec = json.loads(path.read_text())
    rec["ours"] = {"safe_reward": {"reward": {"mean": "abc", "sd": 1.0}, "energy": {"mean": 1.0, "sd": 1.0},
                                   "rpe": {"mean": 0.1, "sd": 0.1}, "episodes": 10}}
    path.write_text(json.dumps(rec))
    out = tmp_path / "page.md"
    assert report.main(["--results", str(res), "--out", str(out), "--notes", "none", "--dcg-notes", "none"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{path}: ours.safe_reward.reward.mean must be a number or null, got 'abc'" in err
    assert not out.exists()


@pytest.mark.parametrize("flag", ["--notes", "--dcg-notes"])
def test_notes_that_are_binary_or_a_folder_name_the_flag_and_the_reason(tmp_path, capsys, flag):
    res = _results_with_one_dcp_table(tmp_path)
    binary = tmp_path / "notes.md"
    binary.write_bytes(b"# notes\n\x80\x81\n")
    other = "--dcg-notes" if flag == "--notes" else "--notes"
    out = str(tmp_path / "page.md")
    assert report.main(["--results", str(res), "--out", out, other, "none", flag, str(binary)]) == 2
    err = capsys.readouterr().err
    assert f"{flag} '{binary}': not a UTF-8 text file" in err and "codec" not in err
    assert report.main(["--results", str(res), "--out", out, other, "none", flag, str(tmp_path)]) == 2
    assert f"{flag} '{tmp_path}' is a folder, not a notes file" in capsys.readouterr().err
    notes, dcg_notes = (str(binary), None) if flag == "--notes" else (None, str(binary))
    with pytest.raises(ValueError, match=rf"{flag} .* not a UTF-8 text file"):
        build_page(str(res), notes, str(tmp_path), dcg_notes)


def test_a_copied_markdown_file_that_is_not_text_is_named(tmp_path):
    res = _results_with_one_dcp_table(tmp_path)
    (res / "benchmarks").mkdir()
    (res / "benchmarks" / "env.md").write_bytes(b"\xff\xfe")
    with pytest.raises(ValueError, match=r"benchmarks/env\.md: not a UTF-8 text file"):
        build_page(str(res), None, str(tmp_path))
