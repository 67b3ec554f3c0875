"""The checks of the DCG's stored results as they are read back: a cached evaluation or bound
(:class:`jaxdc.dcg.analysis.cache.EvaluationCache`) and a figure file (``figure_<experiment>.json``).

A missing or malformed field is a ``ValueError`` naming the file and the key path
(``cache/ab12.json: reward.mean must be a number or null, got 'abc'``), so that a damaged file is refused with
one line and never shown as a bar (issue 31). Extra keys are allowed; the fields the figures, tables, claims and
the results page read are checked.
"""

from __future__ import annotations

from jaxdc.core.claims import AGREES
from jaxdc.core.record_fields import Fields, key_path

#: The statistics of a summary (:meth:`jaxdc.dcg.summary.Summary.to_json`), each ``{"mean", "sd"}``.
STATISTICS = ("reward", "energy", "rpe", "steps")


def _mean_sd(f: Fields, record: dict, key: str, at: str) -> None:
    stat = f.get_obj(record, key, at)
    where = key_path(at, key)
    f.get_number(stat, "mean", where, optional=True)
    f.get_number(stat, "sd", where, optional=True, minimum=0)
    f.get_text(stat, "undefined", where, optional=True, absent=True)


def check_summary(f: Fields, record, at: str = "", *, per_strategy: bool = True) -> dict:
    """``record`` if it is a sound :meth:`~jaxdc.dcg.summary.Summary.to_json` object (with its per-strategy
    summaries when ``per_strategy``; their ``fraction_of_bound`` too)."""
    f.obj(record, at)
    for key in STATISTICS:
        _mean_sd(f, record, key, at)
    f.get_number(record, "episodes", at, integer=True, minimum=0)
    outcomes = f.get_obj(record, "outcomes", at)
    for name, n in outcomes.items():
        f.number(n, key_path(key_path(at, "outcomes"), name), integer=True, minimum=0)
    f.get_number(record, "opponent_accuracy", at, optional=True)
    f.get_number(record, "fraction_of_bound", at, optional=True, absent=True)
    if per_strategy:
        per = f.get_obj(record, "per_strategy", at)
        for name, s in per.items():
            check_summary(f, s, key_path(key_path(at, "per_strategy"), name), per_strategy=False)
    return record


def check_evaluation(f: Fields, record, at: str = "") -> dict:
    """``record`` if it is a sound evaluation (:func:`jaxdc.dcg.analysis.collector_eval.evaluate`'s dict)."""
    check_summary(f, record, at)
    f.get_number(record, "seconds", at, minimum=0)
    f.get_text(record, "net", at)
    f.get_number(record, "alpha", at, optional=True, absent=True)
    f.get_number(record, "seed", at, integer=True)
    f.flag(f.get(record, "greedy", at), key_path(at, "greedy"))
    f.get_text(record, "mask", at, absent=True)
    setting = f.get_obj(record, "setting", at)
    where = key_path(at, "setting")
    for i, s in enumerate(f.get_items(setting, "strategies", where)):
        f.text(s, f"{key_path(where, 'strategies')}[{i}]")
    f.get(setting, "energy", where)
    f.get_number(setting, "reward_area", where, optional=True)
    bound = f.get_obj(record, "bound", at, optional=True)
    if bound is not None:
        f.get_number(bound, "total", key_path(at, "bound"))
        f.get_obj(bound, "per_strategy", key_path(at, "bound"))
    return record


def check_bound(f: Fields, record, at: str = "", *, sampled: bool = True) -> dict:
    """``record`` if it is a sound sampled full-information bound (:func:`jaxdc.dcg.analysis.experiment.game_bound`);
    ``sampled=False``: a figure's bound, sampled or exact (an exact one has no ``se`` or ``episodes``)."""
    f.obj(record, at)
    f.get_number(record, "total", at)
    f.get_number(record, "se", at, minimum=0, absent=not sampled)
    f.get_number(record, "episodes", at, integer=True, minimum=1, absent=not sampled)
    per = f.get_obj(record, "per_strategy", at, optional=True)
    for name, v in (per or {}).items():
        f.number(v, key_path(key_path(at, "per_strategy"), name), optional=True)
    return record


#: What a figure file (``figure_<experiment>.json``) must hold.
FIGURE_FIELDS = ("experiment", "figures", "caption", "command", "results", "claims")


def check_figure(f: Fields, record, *, full: bool = True) -> dict:
    """``record`` if it is a sound figure file of ``python -m eval.dcg figure``
    (:func:`jaxdc.dcg.analysis.report.figure_payload`): its names, every bar of every group, the bounds and the
    judged claims. ``full=False`` checks of each bar only its reward (what the results page reads)."""
    f.obj(record)
    f.get_text(record, "experiment")
    figures = f.get_items(record, "figures")
    if not figures:
        raise f.error("figures", "must name at least one figure")
    for i, fig in enumerate(figures):
        text = f.text(fig, f"figures[{i}]")
        if not all(part.isdigit() for part in text.split(".")):
            raise f.error(f"figures[{i}]", f"must be a figure number such as '5.6', got {text!r}")
    f.get_text(record, "caption")
    f.get_text(record, "command")
    for g, row in f.get_obj(record, "results").items():
        at = key_path("results", g)
        for lb, bar in f.obj(row, at).items():
            where = key_path(at, lb)
            if not full:
                f.obj(bar, where)
                _mean_sd(f, bar, "reward", where)
                continue
            check_evaluation(f, bar, where)
            f.get_text(bar, "file", where)
            f.get_text(bar, "note", where, optional=True)
    for g, b in (f.get_obj(record, "bounds", optional=True) or {}).items():
        check_bound(f, b, key_path("bounds", g), sampled=False)
    for i, c in enumerate(f.get_items(record, "claims")):
        at = f"claims[{i}]"
        f.obj(c, at)
        f.get_text(c, "claim", at)
        f.get_text(c, "ours", at)
        f.get_text(c, "agrees", at, choices=AGREES)
    return record
