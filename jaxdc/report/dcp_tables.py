"""The DCP tables of the results page (Tables 4.1 and 4.3-4.10, section 4.5), thesis beside ours.

Each table is shown with the command that produced it; the ``Δ/SE`` column
gives ours minus the thesis in standard errors of the thesis' mean
(``sd / sqrt(episodes)``), so that a reader can see at a glance which rows
reproduce. A table with a learned row (ENN, the linear learner, EQN) also
shows where its parameters came from and the thesis' incr.% columns (the
learner's increment over each navigator, % of the navigator's mean) beside ours, and the row of the best
shipped jaxdc learner (:mod:`jaxdc.dcp.analysis.best_learner`) compared with the thesis' learned row.
"""

from __future__ import annotations

import math


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def delta_se(ours, thesis, sd, episodes):
    """``(ours - thesis) / (sd / sqrt(episodes))``, or ``None`` when a value is missing or ``sd`` is 0."""
    if not (_finite(ours) and _finite(thesis) and _finite(sd) and sd != 0 and _finite(episodes) and episodes > 0):
        return None
    return (ours - thesis) / (sd / math.sqrt(episodes))


def _se_delta(ours, thesis, sd, episodes):
    d = delta_se(ours, thesis, sd, episodes)
    return "—" if d is None else f"{d:+.1f}"


def _f(x, d):
    """``x`` with ``d`` decimals; a dash for an undefined value (``None``, NaN, infinity)."""
    return f"{x:.{d}f}" if _finite(x) else "—"


def _pm(mean, sd, d):
    return f"{_f(mean, d)} ± {_f(sd, d)}" if _finite(mean) else "—"


def dcp_table(payload: dict) -> str:
    """The markdown of one ``table_<T>.json`` written by ``python -m eval.dcp --table T``."""
    lines = [
        f"### Table {payload['table']}: {payload['caption']}",
        "",
        f"`{payload['command']}`",
        "",
        "| policy | reward thesis | reward ours | Δ/SE | energy thesis | energy ours | RPE thesis | RPE ours |",
        "|---|---|---|---|---|---|---|---|",
    ]
    best = payload.get("best")
    for name, s in payload["ours"].items():
        label, th = name, payload["thesis"].get(name, [None] * 6)
        if best and name == best["row"]:  # compared with the thesis' learned row
            label, th = f"{name}: {best['checkpoint']}", payload["thesis"].get(best["thesis_row"], [None] * 6)
        n = s["episodes"]
        lines.append(
            f"| {label} | {_pm(th[0], th[1], 2)} | {_pm(s['reward']['mean'], s['reward']['sd'], 2)} "
            f"| {_se_delta(s['reward']['mean'], th[0], th[1], n)} "
            f"| {_pm(th[2], th[3], 2)} | {_pm(s['energy']['mean'], s['energy']['sd'], 2)} "
            f"| {_pm(th[4], th[5], 3)} | {_pm(s['rpe']['mean'], s['rpe']['sd'], 3)} |"
        )
    learned = payload.get("learned")
    if learned:
        how = f", trained by `{learned['command']}`" if learned.get("command") else ""
        lines += ["", f"Learned row `{learned['net']}`: parameters `{learned['source']}`{how}."]
    if best:
        lines += ["", f"Row `{best['row']}` (beyond the thesis): the best shipped jaxdc learner for this table, "
                      f"`{best['checkpoint']}` ({best['differs']}{'; played greedily' if best.get('greedy') else ''}), "
                      f"on the same episodes; its thesis columns and Δ/SE are those of the thesis' "
                      f"`{best['thesis_row']}` row."]
    if payload.get("incr"):
        lines += ["", incr_table(payload["incr"])]
    return "\n".join(lines)


def incr_table(incr: dict) -> str:
    """The incr.% columns of Tables 4.3-4.10, thesis beside ours (``jaxdc.core.stats.percent_increase``)."""
    lines = ["| learner's incr.% over | reward thesis | reward ours | energy thesis | energy ours | RPE thesis "
             "| RPE ours |", "|---|---|---|---|---|---|---|"]
    for name, cols in incr.items():
        cells = [_f(v, 2) for col in ("reward", "energy", "rpe") for v in cols[col]]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
