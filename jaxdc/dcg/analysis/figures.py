"""The experiments of section 5.5 (Figs. 5.6-5.19): which networks play which games.

The thesis gives its DCG results as bar charts without printed numbers, so
what can be compared are its *claims* in the text. Each :class:`Experiment`
names its figures, the games it plays (energy levels, reward areas, strategy
set) and the networks it wants (by their training setting, read from the
parameter files' metadata); :mod:`jaxdc.dcg.analysis.claims` puts every
claim of the text beside the numbers we measured.

Networks are chosen from whatever parameter files exist (:func:`select`):
the thesis retrains for the energy levels (5.5.4), for five million steps
(5.5.6) and for the double-blind set (5.5.7); where no network trained that
way is available, the standard network is played in the changed game instead
and the row says so (``note``), or the bar is missing and
:func:`missing` says which training run would fill it.

Beside the thesis' networks, the *strong* ones (trained with the clipped
surrogate, docs/dcg.md "Strong collectors"; beyond the thesis) join the
experiments that name them (:attr:`Experiment.strong`) as bars labelled
``"VNN strong"`` etc., and every claim of the text is checked on them too,
separately from the faithful bars (:func:`family`). Likewise the *general*
ones (trained over a range of maximum energies, ``train.dcg --energy-range``;
docs/generalisation.md) join the experiments over energies
(:attr:`Experiment.general`) as bars labelled ``"OMN+CoNN general"``: one
network playing every energy of the figure, where the thesis trains one per
energy.
"""

from __future__ import annotations

import dataclasses

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
    #: whether the general networks (one for a range of maximum energies covering every group) join the bars
    general: bool = False
    #: whether the charts draw the sampled full-information bound of the game (jaxdc.dcg.exact.many_items)
    game_bound: bool = False
    #: whether a chart of each network's reward per opponent strategy joins the figures (ours, not the thesis')
    per_strategy_chart: bool = False


#: The experiments of section 5.5 by name (Figs. 5.6-5.19).
EXPERIMENTS = {
    "standard": Experiment("standard", ("5.6", "5.7"), "standard setting (5x5, 10 rewards, energy 15), 1M steps",
                           "", (None,), strong="1m", game_bound=True, per_strategy_chart=True),
    "energy": Experiment("energy", ("5.8", "5.9"), "maximum energy 10, 15, 20 (section 5.5.4)", "energy",
                         (10.0, 15.0, 20.0), general=True),
    "area": Experiment("area", ("5.11", "5.12"), "one unit item in the bottom-right s x s reward area "
                       "(section 5.5.5, Fig. 5.10)", "reward area", (1, 2, 3, 4), strong="final"),
    "standard_5m": Experiment("standard_5m", ("5.16", "5.17"), "standard setting, 5M training steps (section 5.5.6)",
                              "", (None,), five_million=True, strong="final",
                              game_bound=True, per_strategy_chart=True),
    "double_blind": Experiment("double_blind", ("5.18", "5.19"), "with-fog replaced by double-blind with-fog "
                               "(section 5.5.7), 1M steps", "", (None,), DOUBLE_BLIND_STRATEGIES,
                               DOUBLE_BLIND_STRATEGIES, per_strategy_chart=True),
}
#: Figure number -> experiment name.
FIGURES = {f: e.name for e in EXPERIMENTS.values() for f in e.figures}


#: The label suffix of a strong network's bar.
STRONG = " strong"
#: The note on a bar of the energy experiment played by the energy-15 network (none retrained at that energy).
ENERGY_15_NOTE = "trained at energy 15"
#: The label suffix of a general network's bar (one network for a range of maximum energies).
GENERAL = " general"


def is_strong(meta: dict) -> bool:
    """Whether ``meta`` describes a strong network: trained with the clipped surrogate (``--clip-eps``), the
    PPO-style recipe of docs/dcg.md, beyond the thesis' A3C."""
    return (meta.get("algorithm") or {}).get("clip_eps") is not None


def label(meta: dict) -> str:
    """The bar label of a network: ``VNN``, ``IMNN``, ``EMNN a=0.001``, ``OMN+CoNN``; ``... strong`` for a strong
    one."""
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
    """Whether ``meta`` describes a network trained as the thesis did: on the standard game (no reward area or
    energy range, which are beyond the thesis), with ``strategies``, at ``energy``, for 1M or 5M steps.

    A strong network (:func:`is_strong`) qualifies only where ``strong`` asks for it: ``"1m"`` one trained
    at most 1M steps, ``"final"`` one trained longer (the recipe's full budget)."""
    steps = meta.get("steps", STEPS_1M)
    if is_strong(meta):
        steps_ok = strong is not None and (steps <= STEPS_1M) == (strong == "1m")
    else:
        steps_ok = (steps >= STEPS_5M) == five_million
    return (steps_ok and meta.get("reward_area") is None and meta.get("energy_range") is None  # one energy
            and tuple(meta.get("strategies", STANDARD_STRATEGIES)) == tuple(strategies)
            and float(meta.get("energy", 15.0)) == float(energy))


def _covers(meta: dict, strategies, energies) -> bool:
    """Whether ``meta`` describes a general network of the standard game (no reward area) trained on
    ``strategies`` over a range of maximum energies that holds every one of ``energies``."""
    r = meta.get("energy_range")
    return (r is not None and meta.get("reward_area") is None and meta.get("collectors", 1) == 1
            and tuple(meta.get("strategies", STANDARD_STRATEGIES)) == tuple(strategies)
            and all(r[0] <= e <= r[1] for e in energies))


def total_steps(pool: dict, name: str) -> int:
    """The training steps of ``pool[name]`` in all: its own and, through ``init_from`` (a warm start), those of
    the network it started from, where that is in ``pool``."""
    seen: set[str] = set()
    total = 0
    while name in pool and name not in seen:
        seen.add(name)
        total += int(pool[name].get("steps", 0))
        name = pool[name].get("init_from")
    return total


def _general(pool: dict, exp: Experiment) -> dict[str, tuple[str, dict]]:
    """``{bar label: (file name, metadata)}``: for each network kind, the general network covering every group of
    ``exp`` that was trained the most steps in all (:func:`total_steps`; ties: the first name)."""
    chosen: dict[str, tuple[str, dict]] = {}
    for name in sorted(pool):
        meta = pool[name]
        if _covers(meta, exp.trained_strategies, exp.groups):
            lab = label(meta).removesuffix(STRONG) + GENERAL
            if lab not in chosen or total_steps(pool, name) > total_steps(pool, chosen[lab][0]):
                chosen[lab] = (name, meta)
    return chosen


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
            note = (ENERGY_15_NOTE if exp.name == "energy"
                    else "trained on the standard set, not retrained" if exp.name == "double_blind" else "")
        entries.append(Entry(lab, name, energy=energy if exp.name == "energy" else None, reward_area=area,
                             strategies=exp.strategies if exp.name == "double_blind" else None, note=note))
    if exp.general:
        for lab, (name, meta) in sorted(_general(pool, exp).items(), key=lambda item: _order(item[1][1])):
            lo, hi = meta["energy_range"]
            masked = f", under the action mask {meta['mask']}" if meta.get("mask", "none") != "none" else ""
            entries.append(Entry(lab, name, energy=energy,
                                 note=f"{name}: one network for energies {lo:g}-{hi:g}{masked}"))
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


def family(results: dict, suffix: str = "") -> dict:
    """The bars of ``results`` of one family: the faithful ones (``suffix=""``), the strong ones (:data:`STRONG`)
    or the general ones (:data:`GENERAL`), under their net's label without the suffix, so that every claim reads
    the same on each."""
    def kind(lb: str) -> str:
        return next((x for x in (STRONG, GENERAL) if lb.endswith(x)), "")

    return {g: {lb.removesuffix(suffix) if suffix else lb: r for lb, r in row.items() if kind(lb) == suffix}
            for g, row in results.items()}
