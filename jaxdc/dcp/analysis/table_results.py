"""The written results of a thesis table (section 4.5): the JSON record and the markdown, thesis beside ours.

A table's rows (:mod:`jaxdc.dcp.analysis.rows`) and Incr.% columns
(:func:`jaxdc.dcp.analysis.tables.incr_rows`) become ``table_<T>.json`` (the command,
the thesis' numbers, ours, the learned row's provenance) and
``table_<T>.md``; the markdown is also what ``python -m eval.dcp`` prints.
"""

from __future__ import annotations

import os

from jaxdc.core.stats import format_number
from jaxdc.dcp.analysis.tables import COLUMNS


def markdown_table(spec, rows: dict, incr: dict | None = None, note: str | None = None) -> str:
    """Mean ± SD of reward, energy and RPE per row (thesis beside ours; ``spec=None``: ours only), then ``note``
    (a paragraph under the table: :func:`best_markdown`), then Incr.%.

    An undefined statistic (mean ``None``: RPE when no episode consumed energy) is a dash.
    """
    head = ("| policy | reward (thesis) | reward (ours) | energy (thesis) | energy (ours) | RPE (thesis) | RPE (ours) "
            "| ours: outcomes |")
    lines = [head, "|" + "---|" * 8]
    for name, s in rows.items():
        th = spec.rows.get(name, (None,) * 6) if spec else (None,) * 6
        cells = [name]
        for col, i in COLUMNS:
            d = 3 if col == "rpe" else 2
            cells.append(f"{format_number(th[i], d)} ± {format_number(th[i + 1], d)}" if th[i] is not None
                         else "—")
            mean, sd = s[col]["mean"], s[col]["sd"]
            cells.append(f"{format_number(mean, d)} ± {format_number(sd, d)}" if mean is not None else "—")
        cells.append(", ".join(f"{k} {v}" for k, v in s["outcomes"].items() if v))
        lines.append("| " + " | ".join(cells) + " |")
    if note:
        lines += ["", note]
    if incr:
        lines += ["", incr_markdown(incr)]
    return "\n".join(lines)


def incr_markdown(incr: dict) -> str:
    """The incr.% columns (learner over each navigator, % of the navigator's mean), thesis beside ours."""
    lines = ["| incr.% over | reward (thesis) | reward (ours) | energy (thesis) | energy (ours) | RPE (thesis) "
             "| RPE (ours) |", "|" + "---|" * 7]
    for name, cols in incr.items():
        cells = [name] + [format_number(v, 2) for col, _ in COLUMNS for v in cols[col]]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def table_markdown_file(spec, command: str, table: str) -> str:
    """The text of ``table_<T>.md``: caption, the command that made it, the table."""
    return f"### Table {spec.name}: {spec.caption}\n\n`{command}`\n\n{table}\n"


def _source(learned) -> str:
    return os.path.relpath(learned.source) if os.path.isabs(learned.source) else learned.source


def learned_info(learned) -> dict:
    """What the results JSON says about a learned row: network, its row, source and how it was trained."""
    meta = learned.metadata
    info = {"net": learned.net_name, "row": learned.net_name, "source": _source(learned),
            "trained": learned.setting()}
    info.update({k: meta[k] for k in ("steps", "seed", "command") if k in meta})
    return info


def best_info(best) -> dict | None:
    """What the results JSON says about the best row (:mod:`jaxdc.dcp.analysis.best_learner`): its row, the thesis
    row it is compared with, the shipped name, source, how its recipe differs, its training setting, greedy play."""
    if best is None:
        return None
    c, row = best
    return {"row": row, "thesis_row": c.learned.net_name, "checkpoint": c.name, "source": _source(c.learned),
            "differs": c.differs, "trained": c.learned.setting(), "greedy": c.greedy,
            **{k: c.learned.metadata[k] for k in ("steps", "command") if k in c.learned.metadata}}


def best_markdown(best) -> str:
    """The line under a table naming its best row's network and how it differs from the thesis' recipe."""
    c, row = best
    return (f"Row `{row}`: the best shipped jaxdc learner for this table, `{c.name}` (beyond the thesis: {c.differs}"
            f"{'; played greedily' if c.greedy else ''}), on the same episodes.")


def table_payload(spec, command: str, rows: dict, incr: dict, learned=None, best=None) -> dict:
    """The record of ``table_<T>.json``: table, caption, command, the thesis' rows, ours, Incr.%, the learner and
    the best shipped learner (``best``: ``(candidate, row)`` or ``None``)."""
    return {"table": spec.name, "caption": spec.caption, "command": command,
            "thesis": {k: list(v) for k, v in spec.rows.items()}, "ours": rows, "incr": incr,
            "learned": learned_info(learned) if learned is not None else None, "best": best_info(best)}
