"""The claims of section 3.5's text about Figs. 3.1-3.5, as data, judged on the stored experiments.

The thesis prints its DRP results as curves without numbers; what can be
compared are the statements of its text (sections 3.5.1-3.5.3). Each
:class:`DrpClaim` names its figure, its text, the experiments it reads (by
node-reward setting, :data:`jaxdc.drp.world.REWARD_SETTINGS`) and a *judge*
that reads their summary rows (:func:`jaxdc.drp.analysis.summary.summarise`) and
returns what was measured and whether the claim holds. :func:`judge_claims`
evaluates them all; a claim whose experiment is missing is ``"n/a"``.

The robot values judged are those the thesis' text names ("below 30",
"around 60"); the order of the builders is judged as the thesis states it:
three groups, ``{GI, TL, LPG} > OSA > {GML, NG}``, at every robot value from
10 to 40 (above 60 "the algorithms rarely send out any robot", section 3.5.2).
"""

from __future__ import annotations

import dataclasses
from typing import Callable, NamedTuple

from jaxdc.core.claims import Verdict, agreement

#: The builders' groups in the thesis' order (section 3.5.1: GI, TL, LPG nearly identical; GML, NG nearly so).
ORDER_GROUPS = (("gi", "tl", "lpg"), ("osa",), ("gml", "ng"))
#: The robot values at which the order is judged (section 3.5.1's figure, below the range where few robots go).
ORDER_ALPHAS = (10, 20, 30, 40)
#: The loss-aware builders that section 3.5.2 says combine well with PGC.
GOOD_BUILDERS = ("gi", "tl", "lpg")


class Judged(NamedTuple):
    """What a claim's judge read: the text shown as "ours" and the verdict (one of
    :data:`jaxdc.core.claims.AGREES`); :func:`judge_claims` turns it into a :class:`jaxdc.core.claims.Verdict`."""

    ours: str
    agrees: str


@dataclasses.dataclass(frozen=True)
class DrpClaim:
    """One statement of section 3.5 about ``figure``; ``judge(rows)`` reads ``rows[rewards]`` (the summary rows
    of the experiments named in ``rewards``, keyed ``(clustering, builder, alpha)``)."""

    figure: str
    text: str
    rewards: tuple
    judge: Callable[[dict], Judged]


def _mean(rows, c, b, a):
    r = rows.get((c, b, a))
    return None if r is None else r["mean"]


def _order_holds(rows, clustering) -> Judged:
    """Every builder of a better group above every builder of the next group, at every alpha of ORDER_ALPHAS."""
    failed = []
    for a in ORDER_ALPHAS:
        for better, worse in zip(ORDER_GROUPS, ORDER_GROUPS[1:]):
            lo = [_mean(rows, clustering, b, a) for b in better]
            hi = [_mean(rows, clustering, b, a) for b in worse]
            if None in lo or None in hi:
                return Judged(f"α = {a}: a builder is missing", "n/a")
            if min(lo) <= max(hi):
                failed.append(a)
                break
    at20 = " > ".join("≈".join(f"{_mean(rows, clustering, b, 20):.3f}" for b in g) for g in ORDER_GROUPS)
    where = "at every α = 10-40" if not failed else f"fails at α = {', '.join(map(str, failed))}"
    return Judged(f"GI≈TL≈LPG > OSA > GML≈NG, {where} (α = 20: {at20})", agreement(not failed))


def _ratio(rows, b, a):
    r = rows.get(("pgc", b, a))
    return None if r is None else r.get("pgc_over_nc")


def _pgc_above_08(rows) -> Judged:
    alphas = sorted({a for (_, _, a) in rows if 0 < a < 30})
    ratios = [_ratio(rows, b, a) for b in GOOD_BUILDERS for a in alphas]
    if not alphas or None in ratios:
        return Judged("no PGC/NC ratio below α = 30", "n/a")
    return Judged(f"GI, TL, LPG at α = {alphas[0]}-{alphas[-1]}: {min(ratios):.2f}-{max(ratios):.2f}",
                  agreement(min(ratios) > 0.8))


def _pgc_about_04(rows) -> Judged:
    ratios = [_ratio(rows, b, 60) for b in GOOD_BUILDERS]
    if None in ratios:
        return Judged("no PGC/NC ratio at α = 60", "n/a")
    shown = " / ".join(f"{r:.2f}" for r in ratios)
    return Judged(f"GI / TL / LPG at α = 60: {shown}", agreement(all(abs(r - 0.4) <= 0.1 for r in ratios)))


def _spread(rows, a=20):
    """GI's normalised mean over NG's under NC at ``a``: how far apart the best and the worst builder are."""
    gi, ng = _mean(rows, "nc", "gi", a), _mean(rows, "nc", "ng", a)
    return None if gi is None or ng is None or ng <= 0 else gi / ng


def _variance_spread(by_rewards) -> Judged:
    s = {k: _spread(v) for k, v in by_rewards.items()}
    if None in s.values():
        return Judged("a GI or NG mean is missing or zero at α = 20", "n/a")
    shown = f"GI/NG under NC at α = 20: {s['1-9']:.2f} (1..9), {s['4-6']:.2f} (4..6), {s['5']:.2f} (5)"
    return Judged(shown, agreement(s["1-9"] > s["4-6"] > s["5"]))


def _pgc_better_for_variance(by_rewards) -> Judged:
    """PGC/NC of the loss-aware builders at alpha 60 with rewards 1..9 against 4..6 and 5."""
    r = {k: [_ratio(v, b, 60) for b in GOOD_BUILDERS] for k, v in by_rewards.items()}
    if any(None in x for x in r.values()):
        return Judged("a PGC/NC ratio at α = 60 is missing", "n/a")
    wide, others = min(r["1-9"]), max(r["4-6"] + r["5"])
    shown = (f"GI/TL/LPG PGC/NC at α = 60: {min(r['1-9']):.2f}-{max(r['1-9']):.2f} (1..9) against "
             f"{min(r['4-6'] + r['5']):.2f}-{others:.2f} (4..6 and 5)")
    return Judged(shown, agreement(wide > others))


def _sd_grows(rows) -> Judged:
    def rel(a):
        r = rows.get(("nc", "gi", a))
        return None if r is None or not r["mean"] else r["sd"] / r["mean"]

    lo, hi = rel(10), rel(60)
    if lo is None or hi is None:
        return Judged("GI under NC at α = 10 or 60 is missing", "n/a")
    return Judged(f"SD / mean of GI under NC: {lo:.3f} at α = 10, {hi:.3f} at α = 60", agreement(hi > lo))


def _one(judge, clustering=None):
    """A judge of one experiment's rows (the claim's only reward setting)."""
    def read(by_rewards):
        (rows,) = by_rewards.values()
        return judge(rows, clustering) if clustering else judge(rows)
    return read


#: Section 3.5's claims, in the order of the text.
CLAIMS = (
    DrpClaim("3.1", "The order from high to low is GI, TL, LPG, OSA, GML and NG, with GI, TL and LPG nearly "
             "identical, and GML and NG nearly identical (NC, rewards 4..6)", ("4-6",), _one(_order_holds, "nc")),
    DrpClaim("3.1", "The standard deviation is relatively large for larger robot values", ("4-6",),
             _one(_sd_grows)),
    DrpClaim("3.2", "With PGC the performance ranking is consistent with the ranking using NC", ("4-6",),
             _one(_order_holds, "pgc")),
    DrpClaim("3.3", "With GI, TL or LPG the PGC/NC ratio is above 0.8 when the robot value is below 30", ("4-6",),
             _one(_pgc_above_08)),
    DrpClaim("3.3", "When the robot value is around 60, the PGC/NC ratio is only about 0.4", ("4-6",),
             _one(_pgc_about_04)),
    DrpClaim("3.4, 3.5", "When node variance becomes larger, the difference in performance becomes larger, and vice "
             "versa", ("1-9", "4-6", "5"), _variance_spread),
    DrpClaim("3.4, 3.5", "Comparing across node variances, PGC performs better for larger node variance",
             ("1-9", "4-6", "5"), _pgc_better_for_variance),
)


def rows_by_key(record: dict) -> dict:
    """The summary rows of one stored experiment (``experiment_record``), keyed ``(clustering, builder, alpha)``."""
    return {(r["clustering"], r["builder"], r["alpha"]): r for r in record["rows"]}


def judge_claims(experiments: dict) -> list[Verdict]:
    """Every claim of :data:`CLAIMS` judged on ``experiments`` (node-reward setting -> stored experiment record),
    with the claim's figure(s) as the verdict's ``source``; ``"n/a"`` where an experiment a claim reads is missing."""
    out = []
    for claim in CLAIMS:
        if any(k not in experiments for k in claim.rewards):
            missing = ", ".join(k for k in claim.rewards if k not in experiments)
            out.append(Verdict(claim.figure, claim.text, f"no experiment with rewards {missing}", "n/a"))
            continue
        judged = claim.judge({k: rows_by_key(experiments[k]) for k in claim.rewards})
        out.append(Verdict(claim.figure, claim.text, judged.ours, judged.agrees))
    return out
