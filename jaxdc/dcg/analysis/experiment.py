"""Running one experiment of section 5.5: every bar of its figures from a pool of parameter files.

:func:`network_pool` reads the metadata of a folder of DCG parameter files;
:func:`run_experiment` plays every bar :func:`jaxdc.dcg.analysis.figures.select`
picks for each group of an :class:`~jaxdc.dcg.analysis.figures.Experiment`
(reusing stored evaluations, :class:`~jaxdc.dcg.analysis.cache.EvaluationCache`),
adds the exact bound of each reward-area game and, for Figs. 5.6 and 5.16, the
sampled full-information bound of the standard game (:func:`game_bound`,
:func:`jaxdc.dcg.exact.many_items.sampled_bound`).
"""

from __future__ import annotations

import dataclasses
import os
from typing import Callable

import jax

from jaxdc import pretrained
from jaxdc.core.record_fields import Fields
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis.cache import EvaluationCache
from jaxdc.dcg.analysis.collector_eval import ExactBounds, evaluate, fraction
from jaxdc.dcg.analysis.figures import Experiment, select
from jaxdc.dcg.analysis.records import check_bound, check_evaluation, check_figure
from jaxdc.dcg.exact.many_items import sampled_bound
from jaxdc.io import read_json, unlimited_to_json


@dataclasses.dataclass(frozen=True)
class ExperimentSettings:
    """How every bar is played: ``episodes`` games of ``PRNGKey(seed)``, sampled or ``greedy``; ``bound``: add
    the full-information bounds, the sampled one over ``bound_episodes`` games of ``PRNGKey(0)``."""

    episodes: int = 10_000
    seed: int = 0
    greedy: bool = False
    bound: bool = True
    bound_episodes: int = 2000


@dataclasses.dataclass(frozen=True)
class ExperimentResults:
    """``results[group][label]``: one evaluation dict per bar (with its parameter ``file`` and ``note``);
    ``bounds[group]``: the full-information bound of that group's game; ``notes[label]``: how a bar differs
    from the thesis' protocol."""

    results: dict
    bounds: dict
    notes: dict


def _num(x, digits: int) -> str:
    return "—" if x is None else f"{x:.{digits}f}"


def group_key(g) -> str:
    """A group value as written in tables and JSON keys: ``all`` for the one group, else ``10``, ``2``, ..."""
    return "all" if g is None else f"{g:g}"


def network_pool(nets_dir: str | None) -> tuple[dict, str]:
    """``{name: metadata}`` of the DCG parameter files in ``nets_dir`` (default: the shipped ones), and the folder.

    A missing default folder gives an empty pool; a missing ``nets_dir`` raises ``ValueError``, and so does a
    file whose stored setting fails the loader's checks (:func:`jaxdc.dcg.learned.check_setting`), naming it.
    """
    folder = nets_dir or os.path.join(pretrained.ASSETS, "dcg")
    if not os.path.isdir(folder):
        if nets_dir:
            raise ValueError(f"--nets-dir: no such folder {nets_dir!r}")
        return {}, folder
    pool = {}
    for f in sorted(os.listdir(folder)):
        if f.endswith(".msgpack"):
            path = os.path.join(folder, f)
            meta = pretrained.read_metadata(path)
            if meta.get("problem") == "dcg":  # checked as the loader checks it: a bad key names the file and key
                pool[f[: -len(".msgpack")]] = learned_lib.check_setting(meta, path)
    return pool, folder


def run_experiment(exp: Experiment, pool: dict, folder: str, settings: ExperimentSettings, cache: EvaluationCache,
                   progress: Callable[[str], None] = print) -> ExperimentResults:
    """Evaluate every bar of ``exp`` (parameter files ``folder/<name>.msgpack`` described by ``pool``)."""
    results, bounds, notes = {}, {}, {}
    loaded = {}
    exact = ExactBounds()
    for g in exp.groups:
        results[g] = {}
        for entry in select(pool, exp, g):
            blob = os.path.join(folder, entry.name + ".msgpack")
            bar = dict(episodes=settings.episodes, seed=settings.seed, energy=entry.energy,
                       strategies=entry.strategies, reward_area=entry.reward_area, greedy=settings.greedy,
                       bound=settings.bound)
            r = cache.load(blob, bar, check_evaluation)
            if r is None:
                if entry.name not in loaded:
                    loaded[entry.name] = learned_lib.load(blob)
                r = evaluate(loaded[entry.name], **bar, bounds=exact)
                cache.store(blob, bar, r)
            r["file"] = entry.name
            r["note"] = entry.note
            results[g][entry.label] = r
            if "bound" in r:
                bounds[g] = r["bound"]
            if entry.note:
                notes[entry.label] = entry.note
            progress(f"  {exp.group_name + ' ' + group_key(g) if g is not None else exp.name}: {entry.label:16s} "
                     f"reward {_num(r['reward']['mean'], 3)}  RPE {_num(r['rpe']['mean'], 4)}  ({r['seconds']:.1f} s)")
    if exp.game_bound and settings.bound and results.get(None):
        first = next(iter(results[None].values()))["file"]
        learned = loaded.get(first) or learned_lib.load(os.path.join(folder, first + ".msgpack"))
        b = game_bound(learned, settings.bound_episodes, cache)
        if b is not None:
            bounds[None] = b
            progress(f"  {exp.name}: full-information bound {b['total']:.3f} ± {b['se']:.3f} "
                     f"({b['episodes']} games)")
            for r in results[None].values():
                r["fraction_of_bound"] = fraction(r["reward"]["mean"], b["total"])
    return ExperimentResults(results, bounds, notes)


def game_bound(learned, episodes: int, cache: EvaluationCache) -> dict | None:
    """The sampled full-information bound (:func:`jaxdc.dcg.exact.many_items.sampled_bound`) of the game
    ``learned`` was trained on, over ``episodes`` games of ``PRNGKey(0)``; stored in ``cache`` per game.
    ``None`` where the search does not apply to the game (``NotImplementedError``)."""
    env, params = learned.game()
    game = {"env": repr(env), "energy": unlimited_to_json(float(params.max_energy)), "max_steps": int(params.max_steps),
            "chase_tie": int(params.chase_tie), "episodes": episodes, "key": 0}
    stored = cache.load(None, game, check_bound)
    if stored is not None:
        return stored
    try:
        res = sampled_bound(env, params, jax.random.PRNGKey(0), episodes)
    except NotImplementedError:
        return None
    out = {"total": res["mean"], "se": res["se"], "episodes": res["episodes"],
           "per_strategy": {k: v["mean"] for k, v in res["per_strategy"].items()}, "game": game}
    cache.store(None, game, out)
    return out


def stored_standard(out: str) -> dict | None:
    """The standard experiment's bars as written to ``out/figure_standard.json`` (``{None: {label: result}}``),
    which the double-blind claims compare with; ``None`` if it was not made. A damaged file
    (:func:`jaxdc.dcg.analysis.records.check_figure`) is a ``ValueError`` naming it and the key."""
    path = os.path.join(out, "figure_standard.json")
    if not os.path.isfile(path):
        return None
    hint = "rerun python -m eval.dcg figure 5.6"
    data = check_figure(Fields(path, hint), read_json(path, hint))
    return {None: data["results"].get("all", {})}
