"""The scorecard at the top of the results page: one row per thesis claim or table, thesis beside jaxdc.

Each row gives what the thesis reports, jaxdc's faithful number (the thesis'
recipe), jaxdc's best number with the option that gives it, a verdict, and a
link to the section below with the command that made it. Every cell is read
from the stored results (``results/``), never typed in:

* DRP, Figs. 3.1-3.5: the claims of section 3.5 (:mod:`jaxdc.drp.analysis.claims`) judged on the largest stored
  experiment of each node-reward setting (``results/drp/experiment_*.json``).
* DCP, Tables 4.1 and 4.3-4.10 (``results/dcp/table_*.json``): the navigators' rows, then the learned row and the
  best shipped learner. ``Δ/SE`` is ours minus the thesis in standard errors ``sd / sqrt(episodes)``;
  ``|Δ/SE| <= 3`` is *reproduced*, beyond that *above* or *below*.
* DCG, Figs. 5.6-5.19 (``results/dcg/figure_*.json``): how many of the thesis' claims about each figure agree,
  on the faithful networks and on the strong ones.
* Beyond the thesis: the exact yardsticks (the single-item DCP optimum, the DCG full-information bound, the DRP
  optimality gaps) against the best jaxdc learner or heuristic.
"""

from __future__ import annotations

import glob
import os
import re

from jaxdc.core.stats import format_number
from jaxdc.dcg.analysis.claims import STRONG_MARK
from jaxdc.dcg.analysis.records import check_bound, check_figure
from jaxdc.drp.analysis.cache import check_experiment, check_gaps
from jaxdc.drp.analysis.claims import judge_claims
from jaxdc.report.dcp_tables import delta_se
from jaxdc.report.stored import dcp_table_file, fields, read_json, read_text, reading, require_fields, table_files

#: ``|Δ/SE|`` up to this is agreement within sampling noise (the thesis' own reruns moved by about 3 SE).
REPRODUCED_SE = 3.0
#: The share of an exact optimum or bound a learner must reach to meet the beyond-the-thesis goals.
YARDSTICK_GOALS = {"dcp_single_item": 0.97}


def verdict(d) -> str:
    """*reproduced*, *above* or *below* for a ``Δ/SE`` of ``d`` (``None``: no thesis number to compare)."""
    if d is None:
        return "—"
    if abs(d) <= REPRODUCED_SE:
        return "reproduced"
    return "above" if d > 0 else "below"


def anchor(title: str) -> str:
    """The GitHub anchor of a markdown heading (lower case, punctuation dropped, spaces to hyphens)."""
    return re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")


def _se(d) -> str:
    return "" if d is None else f" ({d:+.1f} SE)"


# -- DRP ------------------------------------------------------------------------------------------------------
def drp_experiments(results_dir: str) -> dict:
    """The largest stored experiment (graphs x nodes) of each node-reward setting, with its file name."""
    best = {}
    for path in sorted(glob.glob(os.path.join(results_dir, "drp", "experiment_*.json"))):
        rec = require_fields(read_json(path), path, "python -m eval.drp figure", ("config", "rows"))
        check_experiment(rec, path, "rerun python -m eval.drp figure to write it again")
        cfg = rec["config"]
        size = cfg["graphs"] * cfg["nodes"]
        if cfg["rewards"] not in best or size > best[cfg["rewards"]][0]:
            best[cfg["rewards"]] = (size, rec)
    return {k: v[1] for k, v in best.items()}


def drp_rows(results_dir: str) -> list[list[str]]:
    exps = drp_experiments(results_dir)
    if not exps:
        return [["DRP Figs. 3.1-3.5", "section 3.5's claims", "no results: run `python -m eval.drp figure 3.1`",
                 "—", "—", "[drp.md](drp.md)"]]
    scale = ", ".join(f"{k}: {v['config']['graphs']} graphs × {v['config']['nodes']} nodes" for k, v in exps.items())
    rows = []
    for v in judge_claims(exps):
        word = {"yes": "reproduced", "no": "not reproduced", "partly": "partly", "n/a": "n/a"}[v.agrees]
        rows.append([f"DRP Fig. {v.source}", v.claim, v.ours, "—", word,
                     "[drp.md](drp.md#the-thesis-claims-beside-ours) `python -m eval.drp figure "
                     f"{v.source.split(',')[0]}`"])
    rows.append(["DRP", "(scale of the experiments judged)", scale, "", "", ""])
    return rows


# -- DCP ------------------------------------------------------------------------------------------------------
def _row_delta(payload, name, thesis_name=None):
    s = payload["ours"][name]
    th = payload["thesis"].get(thesis_name or name)
    if not th:
        return s["reward"]["mean"], None, None
    return s["reward"]["mean"], th[0], delta_se(s["reward"]["mean"], th[0], th[1], s["episodes"])


def dcp_rows(results_dir: str) -> list[list[str]]:
    rows = []
    for path in table_files(results_dir):
        p = dcp_table_file(path)
        with reading(path, "python -m eval.dcp --table"):
            rows += _dcp_table_rows(p)
    if not rows:
        rows.append(["DCP Tables 4.1, 4.3-4.10", "", "no results: run `python -m eval.dcp --table 4.3`", "—", "—",
                     ""])
    return rows


def _dcp_table_rows(p: dict) -> list[list[str]]:
    """The rows of one table: its navigators (or tour heuristics) together, then its learned row beside the best."""
    rows = []
    title = f"Table {p['table']}: {p['caption']}"
    where = f"[§](#{anchor(title)}) `{p['command']}`"
    learned = (p.get("learned") or {}).get("row")
    best = p.get("best")
    skip = {learned, best["row"] if best else None}
    navs = [n for n in p["ours"] if n not in skip and p["thesis"].get(n) and p["thesis"][n][0] is not None]
    got = [(d, ours / thesis - 1 if thesis else None) for ours, thesis, d in (_row_delta(p, n) for n in navs)
           if d is not None]
    if got:
        ds = [d for d, _ in got]
        within = sum(abs(d) <= REPRODUCED_SE for d in ds)
        worst, rel = max(got, key=lambda g: abs(g[0]))
        label = "tour heuristics" if not learned else "navigators"
        rel_text = "" if rel is None else f", {rel:+.1%}"
        # a row whose Δ/SE is undefined (a null mean, a zero SD) is counted, not silently left out
        undefined = "" if len(got) == len(navs) else f"; {len(navs) - len(got)} more without a Δ/SE"
        rows.append([f"DCP Table {p['table']}", f"{len(ds)} {label}, reward",
                     f"{within} of {len(ds)} within {REPRODUCED_SE:g} SE (largest {worst:+.1f} SE{rel_text})"
                     f"{undefined}", "—",
                     "reproduced" if within == len(ds) else f"{len(ds) - within} of {len(ds)} off", where])
    if learned:
        ours, thesis, d = _row_delta(p, learned)
        cell_best, word_best = "—", ""
        if best:
            b_ours, _, b_d = _row_delta(p, best["row"], best.get("thesis_row") or learned)
            cell_best = f"{format_number(b_ours)}{_se(b_d)}: `{best['checkpoint']}`, {best['differs']}"
            word_best = f"; best: {verdict(b_d)}"
        rows.append([f"DCP Table {p['table']}", f"{learned} reward {format_number(thesis)}",
                     f"{format_number(ours)}{_se(d)}", cell_best, f"faithful: {verdict(d)}{word_best}", where])
    return rows


# -- DCG ------------------------------------------------------------------------------------------------------
#: What the scorecard reads from a DCG figure record.
DCG_FIELDS = ("experiment", "figures", "caption", "command", "results", "claims")


def dcg_figures(results_dir: str) -> list[tuple[str, dict]]:
    """The stored DCG figure records (``figure_*.json``) with their paths, in figure order; a damaged one
    (:func:`jaxdc.dcg.analysis.records.check_figure`, the fields the scorecard reads) is a ``ValueError`` naming the
    file and the key."""
    recs = []
    for path in glob.glob(os.path.join(results_dir, "dcg", "figure_*.json")):
        rec = require_fields(read_json(path), path, "python -m eval.dcg figure", DCG_FIELDS)
        check_figure(fields(path, "python -m eval.dcg figure"), rec, full=False)
        recs.append((tuple(int(x) for x in rec["figures"][0].split(".")), path, rec))
    return [(path, rec) for _, path, rec in sorted(recs, key=lambda kr: (kr[0], kr[1]))]


def _heading(results_dir: str, experiment: str) -> str | None:
    md = os.path.join(results_dir, "dcg", f"figure_{experiment}.md")
    if not os.path.isfile(md):
        return None
    for line in read_text(md).splitlines():
        if line.startswith("#"):
            return line.lstrip("#").strip()
    return None


def _agreement(claims) -> tuple[int, int]:
    judged = [c for c in claims if c["agrees"] in ("yes", "no")]
    return sum(c["agrees"] == "yes" for c in judged), len(judged)


def dcg_rows(results_dir: str) -> list[list[str]]:
    rows = []
    for _, rec in dcg_figures(results_dir):
        thesis = [c for c in rec["claims"] if not c["claim"].startswith(STRONG_MARK)
                  and "beyond the thesis" not in c["claim"]]
        strong = [c for c in rec["claims"] if c["claim"].startswith(STRONG_MARK)
                  and "beyond the thesis" not in c["claim"]]
        yes, n = _agreement(thesis)
        s_yes, s_n = _agreement(strong)
        head = _heading(results_dir, rec["experiment"])
        where = (f"[§](#{anchor(head)}) " if head else "") + f"`{rec['command']}`"
        word = "reproduced" if n and yes == n else "partly" if yes else "not reproduced"
        rows.append([f"DCG Figs. {', '.join(rec['figures'])}", f"{n} claims of the text ({rec['caption']})",
                     f"{yes} of {n} agree", f"{s_yes} of {s_n} agree (strong networks)" if s_n else "—",
                     f"faithful: {word}" + (f"; strong: {s_yes}/{s_n}" if s_n else ""), where])
    if not rows:
        rows.append(["DCG Figs. 5.6-5.19", "", "no results: run `python -m eval.dcg figure all`", "—", "—", ""])
    return rows


# -- beyond the thesis ----------------------------------------------------------------------------------------
def yardstick_rows(results_dir: str) -> list[list[str]]:
    rows = []
    for path in table_files(results_dir):
        p = dcp_table_file(path)
        if "optimal" in p["ours"]:
            with reading(path, "python -m eval.dcp --table"):
                rows.append(_optimum_row(p))
    for path, rec in dcg_figures(results_dir):
        bound = (rec.get("bounds") or {}).get("all")
        if not bound:
            continue
        check_bound(fields(path, "python -m eval.dcg figure"), bound, "bounds.all")  # the scorecard shows its SE
        if "all" not in rec["results"]:
            raise fields(path, "python -m eval.dcg figure").error("results.all", "is missing (bounds.all has a bound)")
        head = _heading(results_dir, rec["experiment"])
        with reading(path, "python -m eval.dcg figure"):
            rows.append(_bound_row(rec, bound, head))
    for _, rec in dcg_figures(results_dir):
        judged = {}
        for c in rec["claims"]:
            if "beyond the thesis" in c["claim"]:
                strong = c["claim"].startswith(STRONG_MARK)
                judged.setdefault(c["claim"].removeprefix(STRONG_MARK), {})["strong" if strong else "faithful"] = c
        for text, by in judged.items():
            cells = [by[k]["ours"] if k in by else "—" for k in ("faithful", "strong")]
            word = "; ".join(f"{k}: {'met' if c['agrees'] == 'yes' else 'not met'}" for k, c in by.items())
            rows.append([f"DCG Figs. {', '.join(rec['figures'])}", text.replace("(beyond the thesis) ", ""), *cells,
                         word, f"`{rec['command']}`"])
    for path in sorted(glob.glob(os.path.join(results_dir, "drp", "gaps_*.json"))):
        rec = check_gaps(read_json(path), path, "rerun python -m eval.drp gaps to write it again")
        with reading(path, "python -m eval.drp gaps"):
            rows += _gap_rows(rec)
    return rows


def _optimum_row(p: dict) -> list[str]:
    """A single-item table's faithful and best learners as shares of its exact optimum (its ``optimal`` row)."""
    opt = float(p["ours"]["optimal"]["expected_optimum"])
    learned, best = (p.get("learned") or {}).get("row"), p.get("best")
    goal = YARDSTICK_GOALS["dcp_single_item"]

    def share(row):
        r = p["ours"][row]["reward"]["mean"]
        return r, "— (undefined)" if r is None else f"{r:.3f} = {r / opt:.1%}"

    cell, met = "—", "—"
    if best:
        r, text = share(best["row"])
        cell = f"{text}: `{best['checkpoint']}`"
        met = "—" if r is None else "goal met" if r / opt >= goal else "goal not met"
    title = f"Table {p['table']}: {p['caption']}"
    return [f"DCP Table {p['table']} setting", f"exact optimum {opt:.3f} (value iteration; not in the thesis); goal "
            f"{goal:.0%}", share(learned)[1] if learned else "—", cell, met, f"[§](#{anchor(title)}) `{p['command']}`"]


def _bound_row(rec: dict, bound: dict, head: str | None) -> list[str]:
    """The best faithful and strong collectors of a DCG experiment as shares of its full-information bound."""
    res, total = rec["results"]["all"], bound["total"]
    def best(strong):
        got = [(v["reward"]["mean"], k) for k, v in res.items()
               if k.endswith(" strong") == strong and v["reward"]["mean"] is not None]
        return "—" if not got else f"{max(got)[0]:.2f} = {max(got)[0] / total:.1%} ({max(got)[1]})"
    return [f"DCG Figs. {', '.join(rec['figures'])}",
            f"full-information bound {total:.2f} ± {bound['se']:.2f} ({bound['episodes']} games; not in the thesis)",
            best(False), best(True), "share of the bound",
            (f"[§](#{anchor(head)}) " if head else "") + f"`{rec['command']}`"]


def _gap_rows(rec: dict) -> list[list[str]]:
    """The best heuristic combination's mean ratio to the exact optimum (``python -m eval.drp gaps``)."""
    rows = [r for r in rec["rows"] if r.get("mean_ratio") is not None]
    if not rows:
        return []
    best = max(rows, key=lambda r: r["mean_ratio"])
    cfg = rec["config"]
    command = (f"python -m eval.drp gaps --graphs {cfg['graphs']} --nodes {cfg['nodes']} --base {cfg['base']}")
    return [["DRP optimality gaps", f"exact optimum of {best['graphs']} graphs of {cfg['nodes']} nodes with a "
             "positive optimum (not in the thesis)", "—",
             f"{best['clustering'].upper()}+{best['builder'].upper()}: {best['mean_ratio']:.3f} of the optimum on "
             f"average, optimal on {best['optimal_share']:.0%}", "—",
             f"[drp.md](drp.md#optimality-gaps-exact-solver-beyond-the-thesis) `{command}`"]]


HEAD = ("| thesis claim or table | thesis | jaxdc, faithful | jaxdc, best (option) | verdict | where, command |\n"
        "|---|---|---|---|---|---|")


def scorecard(results_dir: str) -> str:
    """The scorecard's markdown from the results in ``results_dir``."""
    parts = ["## Scorecard", "",
             "One row per thesis claim or table; every cell is read from `results/` by `python -m eval.report`. "
             f"*Faithful* is the thesis' recipe; *best* the strongest shipped jaxdc option. DCP verdicts: "
             f"|Δ/SE| ≤ {REPRODUCED_SE:g} is reproduced. DCG and DRP: the thesis prints curves and bars, so its "
             "claims are judged as its text states them.", ""]
    for title, rows in (("Chapter 3, DRP", drp_rows(results_dir)), ("Chapter 4, DCP", dcp_rows(results_dir)),
                        ("Chapter 5, DCG", dcg_rows(results_dir)), ("Beyond the thesis", yardstick_rows(results_dir))):
        parts += [f"**{title}**", "", HEAD]
        parts += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in rows]
        parts.append("")
    return "\n".join(parts)
