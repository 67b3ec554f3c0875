"""The section 3.5 experiment's summaries: normalised mean and SD per robot value (section 3.5.1), PGC / NC,
as rows, CSV and markdown tables."""

from __future__ import annotations

import csv
import io
import math

import numpy as np

#: The builders in the thesis' order of quality (section 3.5.1).
QUALITY_ORDER = ("gi", "tl", "lpg", "osa", "gml", "ng")
#: The columns of a summary row (and of the CSV).
ROW_FIELDS = ("clustering", "builder", "alpha", "mean", "sd", "pgc_over_nc")


def summarise(raw, alphas):
    """Normalised mean and SD (section 3.5.1): divided by the mean reward at alpha = 0.

    ``raw[(clustering, builder)]`` is ``[graphs, len(alphas)]`` (:func:`jaxdc.drp.analysis.experiment.run_experiment`);
    the normaliser is the first entry's mean at alpha = 0. Returns ``(normaliser, rows)``, one row per
    ``(clustering, builder, alpha)``; a PGC row also has ``pgc_over_nc`` when NC ran with its builder.
    When the normaliser is not a positive finite number, ``mean`` and ``sd`` are ``None`` and the row's
    ``undefined`` says why (the normaliser is then ``None`` too); ``pgc_over_nc`` is ``None`` when NC's mean
    is not positive.
    """
    i0 = list(alphas).index(0)
    norm = float(np.mean(next(iter(raw.values()))[:, i0]))
    defined = math.isfinite(norm) and norm > 0
    rows = []
    for (c, b), r in raw.items():
        for k, a in enumerate(alphas):
            if defined:
                row = {"clustering": c, "builder": b, "alpha": a, "mean": float(r[:, k].mean() / norm),
                       "sd": float(r[:, k].std() / norm)}
            else:
                row = {"clustering": c, "builder": b, "alpha": a, "mean": None, "sd": None,
                       "undefined": f"the mean reward at alpha = 0 (the normaliser) is {norm:g}, not positive"}
            if c == "pgc" and ("nc", b) in raw:
                nc_mean = raw[("nc", b)][:, k].mean()
                row["pgc_over_nc"] = float(r[:, k].mean() / nc_mean) if nc_mean > 0 else None
            rows.append(row)
    return (norm if defined else None), rows


def rows_csv(rows) -> str:
    """The summary rows as CSV text with the header :data:`ROW_FIELDS`."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(ROW_FIELDS), extrasaction="ignore")  # None: an empty cell
    w.writeheader()
    for r in rows:
        w.writerow(r)
    return buf.getvalue()


def _mean_sd(row) -> str:
    if row["mean"] is None:
        return "–"
    return f"{row['mean']:.3f} ({row['sd']:.3f})"


def markdown_tables(rows, alphas, builders):
    """The experiment's normalised mean (SD) per clustering and PGC/NC as markdown tables, builders in the
    thesis' order of quality (GI, TL, LPG, OSA, GML, NG), at ``alphas``."""
    order = [b for b in QUALITY_ORDER if b in builders]
    at = {(r["clustering"], r["builder"], r["alpha"]): r for r in rows}

    def head(title):
        return [f"| {title} | " + " | ".join(f"α={a:g}" for a in alphas) + " |", "|---|" + "---|" * len(alphas)]

    out = []
    for c in ("nc", "pgc"):
        if not any((c, b, a) in at for b in order for a in alphas):
            continue
        out += head(f"{c.upper()} mean (SD)")
        out += [f"| {b.upper()} | " + " | ".join(_mean_sd(at[c, b, a]) for a in alphas) + " |" for b in order]
        out.append("")
    if any(("pgc", b, a) in at and ("nc", b, a) in at for b in order for a in alphas):
        out += head("PGC / NC")
        out += [f"| {b.upper()} | " + " | ".join("–" if at["pgc", b, a].get("pgc_over_nc") is None else
                                                f"{at['pgc', b, a]['pgc_over_nc']:.2f}" for a in alphas) + " |"
                for b in order]
    return "\n".join(out)


def experiment_record(config, raw, timing, wall_seconds, alphas):
    """What a figure run stores (JSON-ready): its ``config``, wall and per-part times, the normaliser,
    the summary rows and the raw rewards (``"{clustering}_{builder}"``: ``[graphs, alphas]`` lists)."""
    norm, rows = summarise(raw, alphas)
    return {"config": config, "wall_seconds": wall_seconds, "timing": timing, "normaliser": norm, "rows": rows,
            "raw": {f"{c}_{b}": r.tolist() for (c, b), r in raw.items()}}
