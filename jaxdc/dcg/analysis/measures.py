"""The vocabulary of the DCG's claims (section 5.5): the records a claim is made of and the measures that read
the bars.

The thesis gives its DCG results as bar charts without printed numbers; what
can be compared are the claims of its text. A :class:`Claim` record holds the
claim's printed text, the *measure* that reads the bars (a function of
:class:`Bars` returning a :class:`Measured`: the value judged and the text
shown as "ours"), the *test* that judges the value (``holds``, ``about``,
``above``, ``below``, ``at_most``, with its threshold and tolerance) and the
networks it reads. The claims themselves, as data, are
:data:`jaxdc.dcg.analysis.claims.CLAIMS`.

"More", "less", "higher" and "better" between two bars hold only when the
difference exceeds two standard errors (:func:`clearly_above`); a percent
increase is :func:`jaxdc.dcg.evaluate.relative_increase`.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Callable, NamedTuple

from jaxdc.dcg.analysis.figures import ENERGY_15_NOTE, NET_LABELS, label
from jaxdc.dcg.evaluate import relative_increase
from jaxdc.dcg.summary import MeanSD, Summary


class Measured(NamedTuple):
    """What a measure read: the ``value`` its claim's test judges (``None``: a bar is missing) and the text
    shown as "ours"."""

    value: object
    shown: str


class Bar(NamedTuple):
    """One bar of a figure: its statistics, the experiment's note on it (e.g. played by another network) and,
    in a reward-area game, its share of the exact full-information bound."""

    stats: Summary
    note: str = ""
    fraction_of_bound: float | None = None

    @classmethod
    def from_dict(cls, d: dict) -> Bar:
        """The bar of one stored evaluation (:func:`jaxdc.dcg.analysis.collector_eval.evaluate`'s dict, with
        the experiment's ``note``)."""
        return cls(Summary.from_dict(d), d.get("note") or "", d.get("fraction_of_bound"))

    def stat(self, col: str) -> MeanSD:
        """The statistic ``col``: ``"reward"``, ``"energy"``, ``"rpe"`` or ``"steps"``."""
        return getattr(self.stats, col)


def bars_of(results: dict) -> dict:
    """``results[group][label]`` of stored evaluations (dicts) as :class:`Bar` records."""
    return {g: {lb: Bar.from_dict(r) for lb, r in row.items()} for g, row in results.items()}


@dataclasses.dataclass(frozen=True)
class Bars:
    """The bars one claim reads: ``results[group][label]`` (:class:`Bar` records), the standard experiment's
    ``standard`` for the double-blind claims, and the experiment's group values that were played."""

    results: dict
    standard: dict | None
    groups: tuple


#: The figure or section a claim's text cites: "(Fig. 5.6)", "(Fig. 5.6: +9%, ...)", "(5.5.3)".
_SOURCE = re.compile(r"\((?:Fig\. )?(\d+\.\d+(?:\.\d+)?)[:)]")


@dataclasses.dataclass(frozen=True)
class Claim:
    """One claim of the thesis' text about a figure.

    ``text`` is printed as it stands; in a per-network claim set ``{label}`` is the network's bar label.
    ``measure(bars, claim, label)`` reads the bars; ``test`` judges its value against ``threshold`` (``about``:
    within ``tolerance``). ``nets`` are the ``(net, alpha)`` pairs the measure reads; ``only``/``unless``
    restrict a per-network claim to some labels; ``optional`` leaves the row out when the measure has nothing
    to judge.
    """

    text: str
    measure: Callable[[Bars, "Claim", str | None], Measured | None]
    test: str = "holds"
    threshold: float | None = None
    tolerance: float = 0.0
    nets: tuple = ()
    only: tuple = ()
    unless: tuple = ()
    optional: bool = False

    @property
    def source(self) -> str:
        """Where the thesis makes the claim, read from its text: ``"5.6"`` for "(Fig. 5.6)", ``"5.5.3"`` for
        "(5.5.3)"; ``""`` for a claim beyond the thesis."""
        m = _SOURCE.search(self.text)
        return m.group(1) if m else ""


@dataclasses.dataclass(frozen=True)
class ClaimSet:
    """The claims of one experiment; ``per_network``: every claim is made once per network (in bar order)."""

    claims: tuple
    per_network: bool = False


# -- reading bars -----------------------------------------------------------------------------------


def mean(results, group, lab, col="reward"):
    """The mean of ``col`` (``"reward"``, ``"rpe"``, ...) of one bar, ``None`` if the bar is missing."""
    b = results.get(group, {}).get(lab)
    return None if b is None else b.stat(col).mean


def sd(results, group, lab):
    """The episode reward's SD of one bar, ``None`` if the bar is missing."""
    b = results.get(group, {}).get(lab)
    return None if b is None else b.stats.reward.sd


def fmt(x, d=1, suffix=""):
    """A signed number with ``d`` decimals, ``n/a`` for a missing or NaN one."""
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:+.{d}f}{suffix}"


def clearly_above(results_a, group_a, lab_a, results_b, group_b, lab_b, col="reward", k=2.0):
    """Whether bar a's mean exceeds bar b's by more than ``k`` standard errors of the difference
    (independent games); ``None`` if either bar is missing. A bar without an episode count counts as exact."""
    a, b = results_a.get(group_a, {}).get(lab_a), results_b.get(group_b, {}).get(lab_b)
    if a is None or b is None or a.stat(col).mean is None or b.stat(col).mean is None:
        return None
    var = sum(x.stat(col).sd ** 2 / x.stats.episodes for x in (a, b) if x.stats.episodes)
    return a.stat(col).mean - b.stat(col).mean > k * math.sqrt(var)


def _note(results, group, lab) -> str:
    """The experiment's note on one bar, ``""`` without a note or a bar."""
    b = results.get(group, {}).get(lab)
    return "" if b is None else b.note


def find(results, group, net, alpha=None):
    """The label in ``results[group]`` of ``net`` (EMNN: with ``alpha``; else the first EMNN)."""
    labels = list(results.get(group, {}))
    base = NET_LABELS[net]
    if alpha is not None:
        want = label({"net": net, "alpha": alpha})
        return want if want in labels else None
    return next((lb for lb in labels if lb == base or lb.startswith(base + " ")), None)


def best(results, group, col="reward", key=max):
    """The label of the bar with the highest (``key=max``) defined mean of ``col``, ``None`` without bars."""
    row = {lb: b.stat(col).mean for lb, b in results.get(group, {}).items()
           if b.stat(col).mean is not None and not math.isnan(b.stat(col).mean)}
    return key(row, key=row.get) if row else None


def _labels(bars: Bars, claim: Claim) -> list:
    return [find(bars.results, None, net, alpha) for net, alpha in claim.nets]


# -- measures: Figs. 5.6/5.7 (standard, 1M steps) ------------------------------------------------------


def gain_over_vnn(bars, claim, _):
    """The reward of ``claim.nets[0]`` over VNN's, in percent."""
    r = bars.results
    (lab,) = _labels(bars, claim)
    ours = relative_increase(mean(r, None, lab), mean(r, None, find(r, None, "vnn")))
    return Measured(ours, fmt(ours, 1, "%"))


def ranking(bars, claim, _):
    """Whether every network of ``claim.nets`` is clearly above the one before it."""
    r = bars.results
    chain = _labels(bars, claim)
    steps = [None if None in (a, b) else clearly_above(r, None, b, r, None, a) for a, b in zip(chain, chain[1:])]
    return Measured(None if None in steps else all(steps),
                    " < ".join("n/a" if lb is None else f"{lb} {mean(r, None, lb):.2f}" for lb in chain))


def highest_with_smallest_sd(bars, claim, _):
    """Whether ``claim.nets[0]`` has both the highest reward and the smallest SD."""
    r = bars.results
    (lab,) = _labels(bars, claim)
    top = best(r, None)
    low_sd = min(r.get(None, {}), key=lambda lb: sd(r, None, lb)) if r.get(None) else None
    return Measured(None if lab is None else (top == lab and low_sd == lab), f"highest: {top}; smallest SD: {low_sd}")


def rpe_leaders(bars, claim, _):
    """Whether the networks of ``claim.nets`` have the best RPEs, in that order."""
    r = bars.results
    leaders = _labels(bars, claim)
    rpe = {lb: b.stats.rpe.mean for lb, b in r.get(None, {}).items()}
    rank = sorted(rpe, key=lambda lb: (rpe[lb] is None, -(rpe[lb] or 0.0)))  # an undefined RPE ranks last
    return Measured(None if None in leaders else rank[: len(leaders)] == leaders, " > ".join(rank) or "n/a")


def opponent_accuracy(bars, claim, _):
    """The opponent-action accuracy of ``claim.nets[0]`` (another alpha of it if that one is missing)."""
    r = bars.results
    net, alpha = claim.nets[0]
    lab = find(r, None, net, alpha) or find(r, None, net)
    acc = None if lab is None else r[None][lab].stats.opponent_accuracy
    return Measured(acc, "n/a" if acc is None else f"{100 * acc:.1f}%")


# -- measures: Figs. 5.16/5.17 (standard, 5M steps) ----------------------------------------------------


def gains_with_smaller_sds(bars, claim, _):
    """Whether every network of ``claim.nets`` gains more than ``claim.threshold`` percent over VNN, each
    with a smaller SD than VNN's."""
    r = bars.results
    vnn = find(r, None, "vnn")
    others = _labels(bars, claim)
    gains = [relative_increase(mean(r, None, lb), mean(r, None, vnn)) for lb in others]
    ok = None if None in gains or vnn is None else all(x > claim.threshold for x in gains) and all(
        sd(r, None, lb) < sd(r, None, vnn) for lb in others)
    return Measured(ok, ", ".join(f"{lb}: {fmt(x, 1, '%')}" for lb, x in zip(others, gains) if lb))


def best_above(bars, claim, _):
    """Whether ``claim.nets[0]`` has the highest reward and more than ``claim.threshold``."""
    r = bars.results
    (lab,) = _labels(bars, claim)
    m = mean(r, None, lab)
    return Measured(None if m is None else m > claim.threshold and best(r, None) == lab,
                    "n/a" if m is None else f"{m:.2f} (best: {best(r, None)})")


def best_rpe_and_vnn_over_imnn(bars, claim, _):
    """Whether ``claim.nets[0]`` has the best RPE and VNN's RPE is above IMNN's."""
    r = bars.results
    (lab,) = _labels(bars, claim)
    vnn, imnn = find(r, None, "vnn"), find(r, None, "imnn")
    top = best(r, None, "rpe")
    ok = None if None in (lab, vnn, imnn) else top == lab and mean(r, None, vnn, "rpe") > mean(r, None, imnn, "rpe")
    return Measured(ok, f"best RPE: {top}; VNN {fmt(mean(r, None, vnn, 'rpe'), 3)} vs "
                        f"IMNN {fmt(mean(r, None, imnn, 'rpe'), 3)}")


# -- measures: Figs. 5.8/5.9 (energy 10, 15, 20), one per network -------------------------------------

ENERGIES = (10.0, 15.0, 20.0)


def _energy_shown(r, lab, col):
    at = [mean(r, e, lab, col) for e in ENERGIES]
    notes = sorted({_note(r, e, lab) for e in (10.0, 20.0)} - {""})
    how = ("" if not notes else " [played by the energy-15 network: not retrained as in the thesis]"
           if notes == [ENERGY_15_NOTE] else " [" + "; ".join(notes) + "]")
    at10, at20 = relative_increase(at[0], at[1]), relative_increase(at[2], at[1])
    return at, f"10: {fmt(at10, 1, '%')}, 20: {fmt(at20, 1, '%')} vs 15" + how


def more_reward_at_10(bars, claim, lab):
    """Whether the network takes clearly more reward at energy 10 than at 15."""
    r = bars.results
    _, shown = _energy_shown(r, lab, "reward")
    return Measured(clearly_above(r, 10.0, lab, r, 15.0, lab), shown)


def less_at_10_slightly_less_at_20(bars, claim, lab):
    """Whether the network takes clearly less reward at energy 10 than at 15, and at 20 between
    ``claim.threshold`` percent less and the same."""
    r = bars.results
    (r10, r15, r20), shown = _energy_shown(r, lab, "reward")
    return Measured(None if None in (r10, r15, r20) else
                    clearly_above(r, 15.0, lab, r, 10.0, lab)
                    and claim.threshold <= relative_increase(r20, r15) <= 0, shown)


def rpe_higher_at_10_same_at_20(bars, claim, lab):
    """Whether the network's RPE is clearly higher at energy 10 than at 15, and at 20 within
    ``claim.tolerance`` percent of that at 15."""
    r = bars.results
    (q10, q15, q20), shown = _energy_shown(r, lab, "rpe")
    return Measured(None if None in (q10, q15, q20) else
                    clearly_above(r, 10.0, lab, r, 15.0, lab, "rpe")
                    and abs(relative_increase(q20, q15)) <= claim.tolerance, shown)


# -- measures: Figs. 5.11/5.12 (reward areas) ----------------------------------------------------------


def _area_labels(bars):
    return list(bars.results.get(bars.groups[0], {})) if bars.groups else []


def _area_omn(bars):
    return find(bars.results, bars.groups[0], "omn_conn") if bars.groups else None


def falls_as_area_shrinks(bars, claim, _):
    """Whether no network's reward is clearly lower at a larger area than at the next smaller one."""
    r, sizes = bars.results, bars.groups
    mono = {lb: all(clearly_above(r, b, lb, r, a, lb) is not False for a, b in zip(sizes, sizes[1:]))
            for lb in _area_labels(bars)}
    return Measured(all(mono.values()) if mono else None,
                    ", ".join(f"{lb}: {'yes' if ok else 'no'}" for lb, ok in mono.items()) or "n/a")


def beat_vnn_at_every_size(bars, claim, _):
    """Whether every other network is clearly above VNN at every area size."""
    r, labs = bars.results, _area_labels(bars)
    vnn = "VNN" if "VNN" in labs else None
    beat = {s: all(clearly_above(r, s, lb, r, s, vnn) for lb in labs if lb != vnn) for s in bars.groups} \
        if vnn else {}
    return Measured(all(beat.values()) if beat else None,
                    ", ".join(f"size {s}: {'yes' if ok else 'no'}" for s, ok in beat.items()) or "n/a")


def best_at_every_size(bars, claim, _):
    """Whether OMN+CoNN takes the most reward at every area size."""
    bests = {s: best(bars.results, s) for s in bars.groups}
    omn = _area_omn(bars)
    return Measured(None if omn is None else all(b == omn for b in bests.values()),
                    ", ".join(f"size {s}: {b}" for s, b in bests.items()) or "n/a")


def best_rpe_at_small_sizes(bars, claim, _):
    """Whether OMN+CoNN has the best RPE at every area size up to ``claim.threshold``."""
    rpe_best = {s: best(bars.results, s, "rpe") for s in bars.groups}
    omn = _area_omn(bars)
    return Measured(None if omn is None else all(rpe_best[s] == omn for s in bars.groups if s <= claim.threshold),
                    ", ".join(f"size {s}: best {b}" for s, b in rpe_best.items()) or "n/a")


def share_of_bound(bars, claim, _):
    """OMN+CoNN's smallest share of the exact full-information bound over the area sizes; ``None`` (no row)
    without OMN+CoNN or without the bound."""
    r, sizes, omn = bars.results, bars.groups, _area_omn(bars)
    if omn is None or not all(r[s][omn].fraction_of_bound is not None for s in sizes):
        return None
    fr = {s: r[s][omn].fraction_of_bound for s in sizes}
    return Measured(all(f >= claim.threshold for f in fr.values()),
                    ", ".join(f"size {s}: {100 * f:.1f}%" for s, f in fr.items()))


# -- measures: Figs. 5.18/5.19 (double-blind set against the standard one) -----------------------------


def _against_standard(bars, claim):
    r, standard = bars.results, bars.standard
    net = claim.nets[0][0]
    lab = find(r, None, net)
    before = mean(standard or {}, None, find(standard or {}, None, net)) if standard else None
    d = relative_increase(mean(r, None, lab), before)
    note = _note(r, None, lab) if lab else None
    return lab, d, f"{fmt(d, 1, '%')} vs the standard set" + (f" [{note}]" if note else "")


def better_than_standard(bars, claim, _):
    """Whether the network's reward is clearly above its reward against the standard set (Fig. 5.6)."""
    lab, d, shown = _against_standard(bars, claim)
    net = claim.nets[0][0]
    return Measured(None if d is None else clearly_above(bars.results, None, lab, bars.standard, None,
                                                         find(bars.standard, None, net)), shown)


def change_from_standard(bars, claim, _):
    """The network's reward against the double-blind set over that against the standard set, in percent."""
    _, d, shown = _against_standard(bars, claim)
    return Measured(None if d is None else abs(d), shown)


def energy_against_double_blind(bars, claim, _):
    """VNN's energy used per game against the double-blind with-fog opponent."""
    r = bars.results
    vnn = find(r, None, "vnn")
    bar = r.get(None, {}).get(vnn) if vnn else None
    s = (bar.stats.per_strategy or {}).get("double_blind") if bar is not None else None
    return Measured(None if s is None else s.energy.mean,
                    "n/a" if s is None else f"energy used {s.energy.mean:.2f}, reward {s.reward.mean:.2f}, "
                    f"steps {s.steps.mean:.1f} per game")
