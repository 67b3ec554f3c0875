"""The experiments of section 5.5 (Figs. 5.6-5.19): which networks, which games, and the thesis' claims.

The thesis gives its DCG results as bar charts without printed numbers, so
what can be compared are its *claims* in the text. Each :class:`Experiment`
names its figures, the games it plays (energy levels, reward areas, strategy
set) and the networks it wants (by their training setting, read from the
parameter files' metadata), and :func:`claims` puts every claim of the text
beside the numbers we measured.

Networks are chosen from whatever parameter files exist (:func:`select`):
the thesis retrains for the energy levels (5.5.4), for five million steps
(5.5.6) and for the double-blind set (5.5.7); where no network trained that
way is available, the standard network is played in the changed game instead
and the row says so (``note``), or the bar is missing and
:func:`missing` says which training run would fill it.

Beside the thesis' networks, the *strong* ones (trained with the clipped
surrogate, docs/dcg.md "Strong collectors"; beyond the thesis) join the
experiments that name them (:attr:`Experiment.strong`) as bars labelled
``"VNN strong"`` etc., and :func:`claims` checks every claim of the text on
them too, separately from the faithful bars.
"""

from __future__ import annotations

import dataclasses
import math

from jaxdc.dcg.opponents import DOUBLE_BLIND_STRATEGIES, STANDARD_STRATEGIES

#: Training steps of section 5.5.3 and of 5.5.6.
STEPS_1M, STEPS_5M = 1_000_000, 5_000_000
NET_LABELS = {"vnn": "VNN", "imnn": "IMNN", "emnn": "EMNN", "omn_conn": "OMN+CoNN"}
NET_ORDER = ("vnn", "imnn", "emnn", "omn_conn")


@dataclasses.dataclass(frozen=True)
class Experiment:
    """One experiment of section 5.5 and the figures that show it (reward, RPE)."""

    name: str
    figures: tuple  # thesis figure numbers: (reward, RPE)
    caption: str
    group_name: str  # what the bar groups vary ("" for one group)
    groups: tuple  # the group values: energies, reward-area sizes, or (None,)
    strategies: tuple = STANDARD_STRATEGIES  # the opponent set played
    trained_strategies: tuple = STANDARD_STRATEGIES  # the set the wanted networks were trained on
    five_million: bool = False  # wants networks trained for 5M steps (5.5.6)
    #: which strong networks join the bars: "1m" (trained at most 1M steps), "final" (trained longer), or None
    strong: str | None = None
    #: whether the charts draw the sampled full-information bound of the game (jaxdc.dcg.game_optimum)
    game_bound: bool = False


EXPERIMENTS = {
    "standard": Experiment("standard", ("5.6", "5.7"), "standard setting (5x5, 10 rewards, energy 15), 1M steps",
                           "", (None,), strong="1m", game_bound=True),
    "energy": Experiment("energy", ("5.8", "5.9"), "maximum energy 10, 15, 20 (section 5.5.4)", "energy",
                         (10.0, 15.0, 20.0)),
    "area": Experiment("area", ("5.11", "5.12"), "one unit item in the bottom-right s x s reward area "
                       "(section 5.5.5, Fig. 5.10)", "reward area", (1, 2, 3, 4), strong="final"),
    "standard_5m": Experiment("standard_5m", ("5.16", "5.17"), "standard setting, 5M training steps (section 5.5.6)",
                              "", (None,), five_million=True, strong="final",
                              game_bound=True),
    "double_blind": Experiment("double_blind", ("5.18", "5.19"), "with-fog replaced by double-blind with-fog "
                               "(section 5.5.7), 1M steps", "", (None,), DOUBLE_BLIND_STRATEGIES,
                               DOUBLE_BLIND_STRATEGIES),
}
#: Figure number -> experiment name.
FIGURES = {f: e.name for e in EXPERIMENTS.values() for f in e.figures}


#: The label suffix of a strong network's bar.
STRONG = " strong"


def is_strong(meta: dict) -> bool:
    """Whether ``meta`` describes a strong network: trained with the clipped surrogate (``--clip-eps``), the
    PPO-style recipe of docs/dcg.md, beyond the thesis' A3C."""
    return (meta.get("algorithm") or {}).get("clip_eps") is not None


def label(meta: dict) -> str:
    """The bar label of a network: ``VNN``, ``IMNN``, ``EMNN a=0.001``, ``OMN+CoNN``; ``... strong`` for a strong one."""
    name = meta.get("net")
    text = NET_LABELS.get(name, str(name))
    if name == "emnn" and meta.get("alpha") is not None:
        text += f" a={meta['alpha']:g}"
    return text + (STRONG if is_strong(meta) else "")


def _order(meta: dict):
    name = meta.get("net")
    return (is_strong(meta), NET_ORDER.index(name) if name in NET_ORDER else len(NET_ORDER),
            -(meta.get("alpha") or 0.0))


def _trained(meta: dict, strategies, energy: float, five_million: bool, strong: str | None = None) -> bool:
    """Whether ``meta`` describes a network trained as the thesis did: on the standard game (no reward area,
    which is beyond the thesis), with ``strategies``, at ``energy``, for 1M or 5M steps.

    A strong network (:func:`is_strong`) qualifies only where ``strong`` asks for it: ``"1m"`` one trained
    at most 1M steps, ``"final"`` one trained longer (the recipe's full budget)."""
    steps = meta.get("steps", STEPS_1M)
    if is_strong(meta):
        steps_ok = strong is not None and (steps <= STEPS_1M) == (strong == "1m")
    else:
        steps_ok = (steps >= STEPS_5M) == five_million
    return (steps_ok and meta.get("reward_area") is None
            and tuple(meta.get("strategies", STANDARD_STRATEGIES)) == tuple(strategies)
            and float(meta.get("energy", 15.0)) == float(energy))


@dataclasses.dataclass(frozen=True)
class Entry:
    """One bar: which parameter file plays which game."""

    label: str
    name: str  # parameter file name (without .msgpack)
    energy: float | None = None  # None: as trained
    reward_area: int | None = None
    strategies: tuple | None = None  # None: as trained
    note: str = ""  # how this differs from the thesis' protocol, if it does


def select(pool: dict, exp: Experiment, group) -> list[Entry]:
    """The bars of one group of ``exp`` from ``pool`` (``{file name: metadata}``), in the thesis' order.

    Prefers networks trained as the thesis did for that group; otherwise
    plays the standard network in the changed game and says so in ``note``.
    """
    energy = group if exp.name == "energy" else 15.0
    area = group if exp.name == "area" else None

    def pick(strategies, energy_):
        chosen = {}
        for name in sorted(pool):
            meta = pool[name]
            if _trained(meta, strategies, energy_, exp.five_million, exp.strong):
                chosen.setdefault(label(meta), (name, meta))
        return chosen

    exact = pick(exp.trained_strategies, energy)
    fallback = pick(STANDARD_STRATEGIES, 15.0) if not exp.five_million else {}
    entries = []
    for lab in sorted(set(exact) | set(fallback), key=lambda lb: _order((exact.get(lb) or fallback[lb])[1])):
        if lab in exact:
            name, note = exact[lab][0], ""
        else:
            name = fallback[lab][0]
            note = ("trained at energy 15" if exp.name == "energy"
                    else "trained on the standard set, not retrained" if exp.name == "double_blind" else "")
        entries.append(Entry(lab, name, energy=energy if exp.name == "energy" else None, reward_area=area,
                             strategies=exp.strategies if exp.name == "double_blind" else None, note=note))
    return entries


def missing(pool: dict, exp: Experiment) -> list[str]:
    """The thesis' networks of ``exp`` that no parameter file in ``pool`` provides as the thesis trained them."""
    wanted = [("vnn", None), ("imnn", None), ("emnn", 0.001), ("omn_conn", None)]
    if exp.name == "standard":
        wanted.insert(3, ("emnn", 0.0001))
    energies = exp.groups if exp.name == "energy" else (15.0,)
    out = []
    for net, alpha in wanted:
        for e in energies:
            ok = any(m.get("net") == net and (alpha is None or m.get("alpha") == alpha)
                     and _trained(m, exp.trained_strategies, e, exp.five_million) for m in pool.values())
            if not ok:
                what = label({"net": net, "alpha": alpha})
                out.append(f"{what} trained " + ", ".join(filter(None, [
                    f"at energy {e:g}" if exp.name == "energy" else "",
                    "for 5M steps" if exp.five_million else "",
                    "on the double-blind set" if exp.name == "double_blind" else "",
                    "in the standard setting" if exp.name in ("standard", "area") else ""])))
    return out


# -- the thesis' claims beside ours ---------------------------------------------------------------


def _m(results, group, lab, col="reward"):
    s = results.get(group, {}).get(lab)
    return None if s is None else s[col]["mean"]


def _sd(results, group, lab):
    s = results.get(group, {}).get(lab)
    return None if s is None else s["reward"]["sd"]


def _pct(a, b):
    return None if a is None or b is None or b == 0 else 100.0 * (a / b - 1.0)


def _fmt(x, d=1, suffix=""):
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:+.{d}f}{suffix}"


def _clearly_above(results_a, group_a, lab_a, results_b, group_b, lab_b, col="reward", k=2.0):
    """Whether bar a's mean exceeds bar b's by more than ``k`` standard errors of the difference
    (independent games); ``None`` if either bar is missing. A bar without an episode count counts as exact."""
    a, b = results_a.get(group_a, {}).get(lab_a), results_b.get(group_b, {}).get(lab_b)
    if a is None or b is None:
        return None
    var = sum(x[col]["sd"] ** 2 / x["episodes"] for x in (a, b) if x.get("episodes"))
    return a[col]["mean"] - b[col]["mean"] > k * math.sqrt(var)


def _find(results, group, net, alpha=None):
    """The label in ``results[group]`` of ``net`` (EMNN: with ``alpha``; else the first EMNN)."""
    labels = list(results.get(group, {}))
    base = NET_LABELS[net]
    if alpha is not None:
        want = label({"net": net, "alpha": alpha})
        return want if want in labels else None
    return next((lb for lb in labels if lb == base or lb.startswith(base + " ")), None)


def _best(results, group, col="reward", key=max):
    row = {lb: s[col]["mean"] for lb, s in results.get(group, {}).items() if not math.isnan(s[col]["mean"])}
    return key(row, key=row.get) if row else None


def family(results: dict, strong: bool) -> dict:
    """The faithful (``strong=False``) or the strong bars of ``results``, the strong ones under their net's
    label without the suffix, so that every claim reads the same on both."""
    return {g: {lb.removesuffix(STRONG): r for lb, r in row.items() if lb.endswith(STRONG) == strong}
            for g, row in results.items()}


def claims(exp: Experiment, results: dict, standard: dict | None = None) -> list[tuple[str, str, str]]:
    """``(thesis claim, ours, agrees?)`` rows for ``exp``: each claim on the faithful bars, then (where there
    are strong bars) each claim again on the strong ones, marked ``[strong]``. ``standard`` is the standard
    experiment's results (for the double-blind claims). See :func:`_claims`."""
    rows = _claims(exp, family(results, False), family(standard, False) if standard else None)
    strong = family(results, True)
    if any(strong.values()):
        rows += [("[strong] " + c, o, a) for c, o, a in _claims(exp, strong, family(standard, True)
                                                                   if standard else None)]
    return rows


def _claims(exp: Experiment, results: dict, standard: dict | None = None) -> list[tuple[str, str, str]]:
    """``(thesis claim, ours, agrees?)`` rows for ``exp``; ``results[group][label]`` are :func:`summarize` dicts.

    ``agrees`` is ``"yes"``, ``"no"`` or ``"n/a"`` (a network is missing);
    "about X%" claims agree within 5 percentage points; "more", "less",
    "higher" and "better" between two bars only when the difference exceeds
    two standard errors (:func:`_clearly_above`). ``standard`` (the
    standard experiment's results) lets the double-blind claims compare with
    Fig. 5.6.
    """
    rows = []

    def yn(ok):
        return "n/a" if ok is None else ("yes" if ok else "no")

    if exp.name in ("standard", "standard_5m"):
        g = None
        vnn = _find(results, g, "vnn")
        v = _m(results, g, vnn)
        if exp.name == "standard":
            for net, alpha, pct, about in (("imnn", None, 9, True), ("emnn", 0.001, 17, True),
                                           ("omn_conn", None, 19, False)):
                lab = _find(results, g, net, alpha)
                ours = _pct(_m(results, g, lab), v)
                ok = None if ours is None else (abs(ours - pct) <= 5 if about else ours > pct)
                rows.append((f"{label({'net': net, 'alpha': alpha})}: {'about' if about else 'above'} +{pct}% "
                             "episode reward over VNN (Fig. 5.6)", _fmt(ours, 1, "%"), yn(ok)))
            chain = [_find(results, g, "vnn"), _find(results, g, "imnn"), _find(results, g, "emnn", 0.001),
                     _find(results, g, "omn_conn")]
            steps = [None if None in (a, b) else _clearly_above(results, g, b, results, g, a)
                     for a, b in zip(chain, chain[1:])]
            rows.append(("The ranking VNN < IMNN < EMNN < OMN+CoNN (Fig. 5.6: +9%, +17%, above +19%)",
                         " < ".join("n/a" if lb is None else f"{lb} {_m(results, g, lb):.2f}" for lb in chain),
                         yn(None if None in steps else all(steps))))
            omn = _find(results, g, "omn_conn")
            best, low_sd = _best(results, g), (min(results.get(g, {}), key=lambda lb: _sd(results, g, lb))
                                              if results.get(g) else None)
            rows.append(("OMN+CoNN: the highest reward with the smallest SD (Fig. 5.6)",
                         f"highest: {best}; smallest SD: {low_sd}",
                         yn(None if omn is None else (best == omn and low_sd == omn))))
            e4 = _find(results, g, "emnn", 0.0001)
            rank = sorted(results.get(g, {}), key=lambda lb: -results[g][lb]["rpe"]["mean"])
            rows.append(("EMNN a=0.0001 the best RPE, followed by VNN (Fig. 5.7)", " > ".join(rank) or "n/a",
                         yn(None if e4 is None or vnn is None else rank[:2] == [e4, vnn])))
            for net, text, test in (("emnn", "EMNN opponent-action accuracy about 75%", lambda a: abs(a - 0.75) <= 0.05),
                                    ("omn_conn", "OMN opponent-action accuracy over 98%", lambda a: a > 0.98)):
                lab = _find(results, g, net, 0.001 if net == "emnn" else None) or _find(results, g, net)
                acc = None if lab is None else results[g][lab].get("opponent_accuracy")
                rows.append((text + " (5.5.3)", "n/a" if acc is None else f"{100 * acc:.1f}%",
                             yn(None if acc is None else test(acc))))
        else:
            others = [_find(results, g, n) for n in ("imnn", "emnn", "omn_conn")]
            gains = [_pct(_m(results, g, lb), v) for lb in others]
            rows.append(("IMNN, EMNN, OMN+CoNN: more than +15% over VNN, with smaller SDs (Fig. 5.16)",
                         ", ".join(f"{lb}: {_fmt(x, 1, '%')}" for lb, x in zip(others, gains) if lb),
                         yn(None if None in gains or vnn is None else all(x > 15 for x in gains) and all(
                             _sd(results, g, lb) < _sd(results, g, vnn) for lb in others))))
            omn = _find(results, g, "omn_conn")
            r = _m(results, g, omn)
            rows.append(("OMN+CoNN the best, over 9 of 10 rewards, smallest SD (Fig. 5.16)",
                         "n/a" if r is None else f"{r:.2f} (best: {_best(results, g)})",
                         yn(None if r is None else r > 9 and _best(results, g) == omn)))
            imnn = _find(results, g, "imnn")
            rows.append(("OMN+CoNN the best RPE; VNN's RPE above IMNN's (Fig. 5.17)",
                         f"best RPE: {_best(results, g, 'rpe')}; VNN {_fmt(_m(results, g, vnn, 'rpe'), 3)} vs "
                         f"IMNN {_fmt(_m(results, g, imnn, 'rpe'), 3)}",
                         yn(None if None in (omn, vnn, imnn) else _best(results, g, "rpe") == omn and
                            _m(results, g, vnn, "rpe") > _m(results, g, imnn, "rpe"))))
    elif exp.name == "energy":
        labs = sorted({lb for grp in results.values() for lb in grp}, key=lambda lb: list(NET_LABELS.values()).index(
            lb.split(" ")[0]) if lb.split(" ")[0] in NET_LABELS.values() else 9)
        for lb in labs:
            retrained = all(not results.get(e, {}).get(lb, {}).get("note") for e in (10.0, 20.0))
            how = "" if retrained else " [played by the energy-15 network: not retrained as in the thesis]"
            r10, r15, r20 = (_m(results, e, lb) for e in (10.0, 15.0, 20.0))
            q10, q15, q20 = (_m(results, e, lb, "rpe") for e in (10.0, 15.0, 20.0))
            if lb == "VNN":
                rows.append(("VNN: more reward at energy 10 than at 15; similar at 20 (Fig. 5.8)",
                             f"10: {_fmt(_pct(r10, r15), 1, '%')}, 20: {_fmt(_pct(r20, r15), 1, '%')} vs 15" + how,
                             yn(_clearly_above(results, 10.0, lb, results, 15.0, lb))))
            else:
                rows.append((f"{lb}: less reward at energy 10 than at 15; similar but slightly less at 20 (Fig. 5.8)",
                             f"10: {_fmt(_pct(r10, r15), 1, '%')}, 20: {_fmt(_pct(r20, r15), 1, '%')} vs 15" + how,
                             yn(None if None in (r10, r15, r20) else
                                _clearly_above(results, 15.0, lb, results, 10.0, lb) and -10 <= _pct(r20, r15) <= 0)))
            rows.append((f"{lb}: RPE at 20 about that at 15; higher at 10 (Fig. 5.9)",
                         f"10: {_fmt(_pct(q10, q15), 1, '%')}, 20: {_fmt(_pct(q20, q15), 1, '%')} vs 15" + how,
                         yn(None if None in (q10, q15, q20) else
                            _clearly_above(results, 10.0, lb, results, 15.0, lb, "rpe") and abs(_pct(q20, q15)) <= 5)))
    elif exp.name == "area":
        sizes = [s for s in exp.groups if s in results]
        labs = list(results.get(sizes[0], {})) if sizes else []
        mono = {lb: all(_clearly_above(results, b, lb, results, a, lb) is not False for a, b in zip(sizes, sizes[1:]))
                for lb in labs}
        rows.append(("Every network's reward falls as the reward area shrinks (Fig. 5.11)",
                     ", ".join(f"{lb}: {'yes' if ok else 'no'}" for lb, ok in mono.items()) or "n/a",
                     yn(all(mono.values()) if mono else None)))
        vnn = "VNN" if "VNN" in labs else None
        beat = {s: all(_clearly_above(results, s, lb, results, s, vnn) for lb in labs if lb != vnn) for s in sizes} \
            if vnn else {}
        rows.append(("The opponent-modelling networks beat VNN at every size, most at size 1 (Fig. 5.11)",
                     ", ".join(f"size {s}: {'yes' if ok else 'no'}" for s, ok in beat.items()) or "n/a",
                     yn(all(beat.values()) if beat else None)))
        bests = {s: _best(results, s) for s in sizes}
        omn = _find(results, sizes[0], "omn_conn") if sizes else None
        rows.append(("OMN+CoNN collects the item most often, EMNN close behind, IMNN below (Fig. 5.11)",
                     ", ".join(f"size {s}: {b}" for s, b in bests.items()) or "n/a",
                     yn(None if omn is None else all(b == omn for b in bests.values()))))
        rpe_best = {s: _best(results, s, "rpe") for s in sizes}
        rows.append(("RPE falls with the area; OMN+CoNN dominates at small sizes (Fig. 5.12)",
                     ", ".join(f"size {s}: best {b}" for s, b in rpe_best.items()) or "n/a",
                     yn(None if omn is None else all(rpe_best[s] == omn for s in sizes if s <= 2))))
        if omn is not None and all(results[s][omn].get("fraction_of_bound") is not None for s in sizes):
            fr = {s: results[s][omn]["fraction_of_bound"] for s in sizes}
            rows.append(("(beyond the thesis) OMN+CoNN >= 90% of the full-information bound at every size",
                         ", ".join(f"size {s}: {100 * f:.1f}%" for s, f in fr.items()),
                         yn(all(f >= 0.9 for f in fr.values()))))
    elif exp.name == "double_blind":
        g = None
        for net, better in (("vnn", True), ("imnn", True), ("emnn", None), ("omn_conn", None)):
            lab = _find(results, g, net)
            now = _m(results, g, lab)
            before = _m(standard or {}, g, _find(standard or {}, g, net)) if standard else None
            d = _pct(now, before)
            claim = (f"{NET_LABELS[net]}: better than in Fig. 5.6" if better
                     else f"{NET_LABELS[net]}: about the same as in Fig. 5.6")
            ok = None if d is None else (_clearly_above(results, g, lab, standard, g, _find(standard, g, net))
                                         if better else abs(d) <= 5)
            note = results.get(g, {}).get(lab, {}).get("note") if lab else None
            rows.append((claim + " (Fig. 5.18)", f"{_fmt(d, 1, '%')} vs the standard set"
                         + (f" [{note}]" if note else ""), yn(ok)))
        vnn = _find(results, g, "vnn")
        s = results.get(g, {}).get(vnn, {}).get("per_strategy", {}).get("double_blind") if vnn else None
        rows.append(("VNN simply stays in the base against double-blind with-fog (5.5.7)",
                     "n/a" if s is None else f"energy used {s['energy']['mean']:.2f}, reward "
                     f"{s['reward']['mean']:.2f}, steps {s['steps']['mean']:.1f} per game",
                     yn(None if s is None else s["energy"]["mean"] < 1.0)))
    return rows
