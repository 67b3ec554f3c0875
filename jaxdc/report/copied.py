"""Markdown written by other commands, copied into the results page with its links fixed.

The DCG figures (section 5.5) and the benchmark tables are copied in as their
commands wrote them (each names its command; image links are rewritten for
the page's folder); a section with no results yet says which command to run.
"""

from __future__ import annotations

import glob
import os
import re

from jaxdc.report.stored import read_text

#: The title of the DCG section (its hand-written notes are appended to it).
DCG_TITLE = "DCG (chapter 5): Figs. 5.6-5.19"
#: Markdown tables written by the other commands, copied into the page: (section title, glob under results/,
#: the command that makes them when there are none).
SECTIONS = (
    (DCG_TITLE, "dcg/figure_*.md", "python -m eval.dcg figure all"),
    ("Benchmarks", "benchmarks/**/*.md", "python benchmarks/env_throughput.py; python benchmarks/train_throughput.py"),
)


def _relink(text: str, source: str, out_dir: str) -> str:
    """Rewrite relative image/link targets of a markdown file at ``source`` for a page written in ``out_dir``."""
    def fix(m):
        target = m.group(2)
        if "://" in target or target.startswith(("/", "#")):
            return m.group(0)
        new = os.path.relpath(os.path.normpath(os.path.join(os.path.dirname(source), target)), out_dir)
        return f"{m.group(1)}({new})"

    return re.sub(r"(!?\[[^\]]*\])\(([^)\s]+)\)", fix, text)


def copied_sections(results_dir: str, out_dir: str, notes: dict | None = None) -> list[str]:
    """The DCG figure and benchmark tables found in ``results_dir`` (each carries its command), or what to run;
    ``notes[title]`` (hand-written markdown) ends the section of that title."""
    parts = []
    notes = notes or {}
    for title, pattern, command in SECTIONS:
        files = sorted(glob.glob(os.path.join(results_dir, pattern), recursive=True))
        parts += [f"## {title}", ""]
        if not files:
            parts += [f"No results yet: run `{command}`, then `python -m eval.report`.", ""]
        for path in files:
            text = read_text(path).strip()
            if "`python" not in text:  # a table written without its command: name the script that writes it
                text = f"`python benchmarks/{os.path.basename(path)[:-3]}.py`\n\n{text}"
            parts += [f"<!-- from {os.path.relpath(path, results_dir)} -->", _relink(text, path, out_dir), ""]
        if notes.get(title):
            parts += [notes[title].strip(), ""]
    parts += ["## DRP (chapter 3)", "",
              "The DRP figures (3.1-3.5), their commands and the optimality gaps are on [drp.md](drp.md).", ""]
    return parts
