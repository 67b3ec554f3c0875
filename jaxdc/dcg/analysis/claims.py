"""The claims the thesis' text makes about its DCG figures (section 5.5), as data, judged on our numbers.

:data:`CLAIMS` lists, per experiment, the thesis' claims as
:class:`~jaxdc.dcg.analysis.measures.Claim` records (their vocabulary and
measures are :mod:`jaxdc.dcg.analysis.measures`); :func:`claims` judges them
all with one generic loop into :class:`jaxdc.core.claims.Verdict` rows, the
record every problem's claims share (``source``: the figure or section the
claim cites).

``agrees`` is ``"yes"``, ``"no"`` or ``"n/a"`` (a network is missing).
"About X%" claims agree within 5 percentage points; "more", "less", "higher"
and "better" between two bars only when the difference exceeds two standard
errors (:func:`~jaxdc.dcg.analysis.measures.clearly_above`).
"""

from __future__ import annotations

from jaxdc.core.claims import Verdict, agreement
from jaxdc.dcg.analysis.figures import GENERAL, NET_LABELS, STRONG, Experiment, family
from jaxdc.dcg.analysis.measures import (
    Bars,
    Claim,
    ClaimSet,
    bars_of,
    beat_vnn_at_every_size,
    best_above,
    best_at_every_size,
    best_rpe_and_vnn_over_imnn,
    best_rpe_at_small_sizes,
    better_than_standard,
    change_from_standard,
    energy_against_double_blind,
    falls_as_area_shrinks,
    gain_over_vnn,
    gains_with_smaller_sds,
    highest_with_smallest_sd,
    less_at_10_slightly_less_at_20,
    more_reward_at_10,
    opponent_accuracy,
    ranking,
    rpe_higher_at_10_same_at_20,
    rpe_leaders,
    share_of_bound,
)

# -- the claims ------------------------------------------------------------------------------------

#: ``(net, alpha)`` of the networks the claims name; ``EMNN``: the first EMNN bar, whatever its alpha.
VNN, IMNN, OMN = ("vnn", None), ("imnn", None), ("omn_conn", None)
EMNN, EMNN_3, EMNN_4 = ("emnn", None), ("emnn", 0.001), ("emnn", 0.0001)

#: The thesis' claims per experiment (:data:`jaxdc.dcg.analysis.figures.EXPERIMENTS`), in the order printed.
CLAIMS = {
    "standard": ClaimSet((
        Claim("IMNN: about +9% episode reward over VNN (Fig. 5.6)", gain_over_vnn, "about", 9, 5, (IMNN,)),
        Claim("EMNN a=0.001: about +17% episode reward over VNN (Fig. 5.6)", gain_over_vnn, "about", 17, 5,
              (EMNN_3,)),
        Claim("OMN+CoNN: above +19% episode reward over VNN (Fig. 5.6)", gain_over_vnn, "above", 19, nets=(OMN,)),
        Claim("The ranking VNN < IMNN < EMNN < OMN+CoNN (Fig. 5.6: +9%, +17%, above +19%)", ranking,
              nets=(VNN, IMNN, EMNN_3, OMN)),
        Claim("OMN+CoNN: the highest reward with the smallest SD (Fig. 5.6)", highest_with_smallest_sd, nets=(OMN,)),
        Claim("EMNN a=0.0001 the best RPE, followed by VNN (Fig. 5.7)", rpe_leaders, nets=(EMNN_4, VNN)),
        Claim("EMNN opponent-action accuracy about 75% (5.5.3)", opponent_accuracy, "about", 0.75, 0.05, (EMNN_3,)),
        Claim("OMN opponent-action accuracy over 98% (5.5.3)", opponent_accuracy, "above", 0.98, nets=(OMN,)),
    )),
    "standard_5m": ClaimSet((
        Claim("IMNN, EMNN, OMN+CoNN: more than +15% over VNN, with smaller SDs (Fig. 5.16)", gains_with_smaller_sds,
              threshold=15, nets=(IMNN, EMNN, OMN)),
        Claim("OMN+CoNN the best, over 9 of 10 rewards, smallest SD (Fig. 5.16)", best_above, threshold=9,
              nets=(OMN,)),
        Claim("OMN+CoNN the best RPE; VNN's RPE above IMNN's (Fig. 5.17)", best_rpe_and_vnn_over_imnn, nets=(OMN,)),
    )),
    "energy": ClaimSet((
        Claim("VNN: more reward at energy 10 than at 15; similar at 20 (Fig. 5.8)", more_reward_at_10,
              only=("VNN",)),
        Claim("{label}: less reward at energy 10 than at 15; similar but slightly less at 20 (Fig. 5.8)",
              less_at_10_slightly_less_at_20, threshold=-10, unless=("VNN",)),
        Claim("{label}: RPE at 20 about that at 15; higher at 10 (Fig. 5.9)", rpe_higher_at_10_same_at_20,
              tolerance=5),
    ), per_network=True),
    "area": ClaimSet((
        Claim("Every network's reward falls as the reward area shrinks (Fig. 5.11)", falls_as_area_shrinks),
        Claim("The opponent-modelling networks beat VNN at every size, most at size 1 (Fig. 5.11)",
              beat_vnn_at_every_size),
        Claim("OMN+CoNN collects the item most often, EMNN close behind, IMNN below (Fig. 5.11)", best_at_every_size),
        Claim("RPE falls with the area; OMN+CoNN dominates at small sizes (Fig. 5.12)", best_rpe_at_small_sizes,
              threshold=2),
        Claim("(beyond the thesis) OMN+CoNN >= 90% of the full-information bound at every size", share_of_bound,
              threshold=0.9, optional=True),
    )),
    "double_blind": ClaimSet((
        Claim("VNN: better than in Fig. 5.6 (Fig. 5.18)", better_than_standard, nets=(VNN,)),
        Claim("IMNN: better than in Fig. 5.6 (Fig. 5.18)", better_than_standard, nets=(IMNN,)),
        Claim("EMNN: about the same as in Fig. 5.6 (Fig. 5.18)", change_from_standard, "at_most", 5, nets=(EMNN,)),
        Claim("OMN+CoNN: about the same as in Fig. 5.6 (Fig. 5.18)", change_from_standard, "at_most", 5, nets=(OMN,)),
        Claim("VNN simply stays in the base against double-blind with-fog (5.5.7)", energy_against_double_blind,
              "below", 1.0),
    )),
}


# -- the evaluator ---------------------------------------------------------------------------------

#: How a claim's test judges a measured value (never called with ``None``).
TESTS = {
    "holds": lambda v, c: bool(v),
    "about": lambda v, c: abs(v - c.threshold) <= c.tolerance,
    "above": lambda v, c: v > c.threshold,
    "below": lambda v, c: v < c.threshold,
    "at_most": lambda v, c: v <= c.threshold,
}


def _network_order(lab: str) -> int:
    name = lab.split(" ")[0]
    return list(NET_LABELS.values()).index(name) if name in NET_LABELS.values() else 9


def _judge(claim: Claim, bars: Bars, lab: str | None) -> Verdict | None:
    m = claim.measure(bars, claim, lab)
    if m is None:
        return None
    ok = None if m.value is None else TESTS[claim.test](m.value, claim)
    return Verdict(claim.source, claim.text.format(label=lab), m.shown, agreement(ok))


def _verdicts(exp: Experiment, results: dict, standard: dict | None) -> list[Verdict]:
    bars = Bars(bars_of(results), None if standard is None else bars_of(standard),
                tuple(g for g in exp.groups if g in results))
    cset = CLAIMS[exp.name]
    # per network in bar order; two bars of one network (EMNN's alphas) in the order they were played
    labs = (sorted(dict.fromkeys(lb for row in results.values() for lb in row), key=_network_order)
            if cset.per_network else [None])
    rows = []
    for lab in labs:
        for claim in cset.claims:
            if (claim.only and lab not in claim.only) or lab in claim.unless:
                continue
            v = _judge(claim, bars, lab)
            if v is not None:
                rows.append(v)
    return rows


#: The mark before a claim judged again on the strong (beyond-the-thesis) networks.
STRONG_MARK = "[strong] "
#: The mark before a claim judged again on the general networks (one for a range of energies; beyond the thesis).
GENERAL_MARK = "[general] "


def claims(exp: Experiment, results: dict, standard: dict | None = None) -> list[Verdict]:
    """The :class:`Verdict` rows of ``exp``: each claim of :data:`CLAIMS` on the faithful bars, then (where
    there are strong bars) each claim again on the strong ones, marked ``[strong]``, and (where there are general
    bars) on the general ones, marked ``[general]``. ``results[group][label]``
    are stored evaluations (:func:`jaxdc.dcg.analysis.collector_eval.evaluate` dicts), read as
    :class:`~jaxdc.dcg.analysis.measures.Bar` records; ``standard`` is the standard experiment's results (for the
    double-blind claims, which compare with Fig. 5.6)."""
    rows = _verdicts(exp, family(results), family(standard) if standard else None)
    for suffix, mark in ((STRONG, STRONG_MARK), (GENERAL, GENERAL_MARK)):
        bars = family(results, suffix)
        if any(bars.values()):
            rows += [v._replace(claim=mark + v.claim)
                     for v in _verdicts(exp, bars, family(standard, suffix) if standard else None)]
    return rows
