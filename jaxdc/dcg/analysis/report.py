"""Results of section 5.5 as text: one evaluation's report and file name, a figure's tables and JSON payload,
and the sampled full-information bound's record.

These turn the dicts of :func:`jaxdc.dcg.analysis.collector_eval.evaluate` (a figure's bars read as
:class:`~jaxdc.dcg.analysis.measures.Bar` records),
:func:`jaxdc.dcg.analysis.experiment.run_experiment` and
:func:`jaxdc.dcg.exact.many_items.sampled_bound` into what ``python -m eval.dcg``
prints and writes; they compute nothing.
"""

from __future__ import annotations

import csv
import hashlib
import io
import os

import numpy as np

from jaxdc.core.claims import Verdict
from jaxdc.dcg.analysis.experiment import ExperimentResults, group_key
from jaxdc.dcg.analysis.figures import Experiment
from jaxdc.dcg.analysis.measures import bars_of
from jaxdc.dcg.opponents import DOUBLE_BLIND_STRATEGIES, STANDARD_STRATEGIES
from jaxdc.dcg.summary import MeanSD
from jaxdc.io import unlimited_to_json

# -- one evaluation -------------------------------------------------------------------------------
#: How the text reports show a statistic that is undefined (``null`` in JSON, an empty CSV cell).
UNDEFINED = "—"


def _mean_sd(stat: MeanSD, digits: int) -> str:
    """``mean ± sd`` with ``digits`` decimals, or :data:`UNDEFINED` (with its reason) when there is no mean."""
    if stat.mean is None:
        return UNDEFINED + (f" ({stat.undefined})" if stat.undefined else "")
    return f"{stat.mean:.{digits}f} ± {stat.sd:.{digits}f}"


def _setting_text(x) -> str:
    """An energy setting in a file name: ``15``, ``inf`` (JSON writes unlimited energy as ``"inf"``)."""
    return x if isinstance(x, str) else f"{x:g}"


def _strategy_set(strategies) -> str:
    """A strategy set in a file name: ``standard``, ``double_blind`` or the names joined by ``-``."""
    return "standard" if tuple(strategies) == STANDARD_STRATEGIES else (
        "double_blind" if tuple(strategies) == DOUBLE_BLIND_STRATEGIES else "-".join(strategies))


def result_name(r: dict) -> str:
    """The file name of an evaluation:
    ``eval_<net>[_a<alpha>]_e<energy>_<set>[_area<S>][_greedy][_mask-<mask>][_run<S>]_s<seed>.json``."""
    s = r["setting"]
    sets = _strategy_set(s["strategies"])
    parts = [f"eval_{r['net']}"]
    if r["net"] == "emnn" and r.get("alpha") is not None:
        parts.append(f"a{r['alpha']:g}")
    parts += [f"e{_setting_text(s['energy'])}", sets]
    if s["reward_area"] is not None:
        parts.append(f"area{s['reward_area']}")
    if r["greedy"]:
        parts.append("greedy")
    if r.get("mask"):
        parts.append(f"mask-{r['mask']}")
    parts += _run_part(r)
    parts.append(f"s{r['seed']}")
    return "_".join(parts) + ".json"


def source_stem(source: str) -> str:
    """A network's parameter file or run folder as a file-name stem: ``team2`` for ``.../team2.msgpack``."""
    stem = os.path.basename(str(source).rstrip(os.sep))
    if stem == "checkpoints":  # a run folder's checkpoints: the folder's name
        stem = os.path.basename(os.path.dirname(str(source).rstrip(os.sep)))
    return stem[: -len(".msgpack")] if stem.endswith(".msgpack") else stem


def team_result_name(r: dict) -> str:
    """The file name of a team evaluation (:func:`jaxdc.dcg.analysis.team.evaluate_learned`):
    ``team_<net-file>_k<K>_e<energy>_<set>[_greedy][_run<S>]_s<seed>.json``."""
    s = r["setting"]
    return "_".join([f"team_{source_stem(r['source'])}", f"k{r['collectors']}", f"e{_setting_text(s['energy'])}",
                     _strategy_set(s["strategies"])] + (["greedy"] if r["greedy"] else []) + _run_part(r)
                    + [f"s{r['seed']}"]) + ".json"


def _run_part(r: dict) -> list[str]:
    """``["run<S>"]`` for one seed of a ``train.dcg --seeds`` run folder (the seeds share the folder's name)."""
    return [] if r.get("run_seed") is None else [f"run{r['run_seed']}"]


def team_report(r: dict) -> str:
    """The text report of a team evaluation: the team reward, the games cleared, the captures, per strategy."""
    who = (f"{r['collectors']} copies of {r['net']}" if r["team"] == "copies"
           else f"{r['net']} trained as a team of {r['collectors']}")
    reward = r["reward"]
    spread = "" if reward["sd"] is None else f" ± {reward['se']:.3f} SE (SD {reward['sd']:.3f})"
    lines = [f"{who}, {r['episodes']} games: team reward {reward['mean']:.3f}{spread}",
             f"cleared {100 * r['cleared']:.1f}% of games; {100 * r['caught_collectors']:.1f}% of collectors caught, "
             f"a capture in {100 * r['any_caught']:.1f}% of games"]
    lines += [f"  {name}: {UNDEFINED if v is None else f'{v:.3f}'}" for name, v in r["per_strategy"].items()]
    return "\n".join(lines)


def _line(r: dict, bound: float | None) -> str:
    acc = r["opponent_accuracy"]
    steps = UNDEFINED if r["steps"]["mean"] is None else f"{r['steps']['mean']:.1f}"
    reward, rpe = _mean_sd(MeanSD.from_dict(r["reward"]), 3), _mean_sd(MeanSD.from_dict(r["rpe"]), 4)
    text = f"reward {reward}   RPE {rpe}   steps {steps}"
    if acc is not None:
        text += f"   opponent accuracy {100 * acc:.1f}%"
    if r.get("fraction_of_bound") is not None and bound is not None:
        text += f"   {100 * r['fraction_of_bound']:.1f}% of the bound {bound:.4f}"
    return text


def report(r: dict) -> str:
    """The text report of one evaluation: totals, outcomes and one line per strategy (each with its share of
    its own exact bound in a reward-area game)."""
    bound = r.get("bound") or {"total": None, "per_strategy": {}}
    lines = [f"all ({r['episodes']} games)".ljust(24) + _line(r, bound["total"]),
             "outcomes: " + ", ".join(f"{k} {v}" for k, v in r["outcomes"].items())]
    for name, s in r["per_strategy"].items():
        lines.append(f"{name} ({s['episodes']})".ljust(24) + _line(s, bound["per_strategy"].get(name)))
    return "\n".join(lines)


# -- one figure -----------------------------------------------------------------------------------
def figure_csv(results: dict) -> str:
    """One CSV row per bar and strategy (``all`` first) of ``results[group][label]``; an undefined statistic
    (``None``) is an empty cell."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["group", "network", "strategy", "episodes", "reward_mean", "reward_sd", "rpe_mean", "rpe_sd",
                "energy_mean", "steps_mean", "opponent_accuracy", "fraction_of_bound", "file", "note"])
    for g, row in results.items():
        for lb, r in row.items():
            for strat, s in [("all", r)] + list(r["per_strategy"].items()):
                w.writerow([group_key(g), lb, strat, s["episodes"], s["reward"]["mean"], s["reward"]["sd"],
                            s["rpe"]["mean"], s["rpe"]["sd"], s["energy"]["mean"], s["steps"]["mean"],
                            s.get("opponent_accuracy"), s.get("fraction_of_bound"), r["file"], r["note"]])
    return buf.getvalue()


def figure_markdown(exp: Experiment, data: ExperimentResults, verdicts: list[Verdict], missing: list[str],
                    command: str, images: list[str]) -> str:
    """The markdown section of one experiment: the command, its images, one table row per bar, the claims."""
    results = data.results
    lines = [f"### Figs. {' and '.join(exp.figures)}: {exp.caption}", "", f"`{command}`", ""]
    for img in images:
        lines.append(f"![{os.path.basename(img)}]({img})")
    lines += ["", "| " + (exp.group_name + " | " if exp.group_name else "") +
              "network | reward | RPE | opponent accuracy | " + ("bound / fraction | " if data.bounds else "")
              + " | ".join(f"{s} reward" for s in exp.strategies) + " | note |",
              "|" + "---|" * (5 + bool(exp.group_name) + bool(data.bounds) + len(exp.strategies))]
    for g, row in bars_of(results).items():
        for lb, bar in row.items():
            acc, per = bar.stats.opponent_accuracy, bar.stats.per_strategy or {}
            cells = ([group_key(g)] if exp.group_name else []) + [
                lb, _mean_sd(bar.stats.reward, 3), _mean_sd(bar.stats.rpe, 4),
                "—" if acc is None else f"{100 * acc:.1f}%"]
            if data.bounds:
                b = data.bounds.get(g)
                fr = bar.fraction_of_bound
                cells.append("—" if b is None else f"{b['total']:.4f} / " + ("—" if fr is None else f"{100 * fr:.1f}%"))
            cells += [f"{per[s].reward.mean:.3f}" if s in per and per[s].reward.mean is not None else "—"
                      for s in exp.strategies]
            cells.append(bar.note)
            lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "| thesis claim | ours | agrees |", "|---|---|---|"]
    lines += [f"| {v.claim} | {v.ours} | {v.agrees} |" for v in verdicts]
    if missing:
        lines += ["", "Missing networks (no parameter file trained as the thesis did): " + "; ".join(missing) + "."]
    return "\n".join(lines) + "\n"


def figure_payload(exp: Experiment, data: ExperimentResults, verdicts: list[Verdict], missing: list[str], *,
                   command: str, episodes: int, seed: int, greedy: bool) -> dict:
    """The JSON record of one experiment: its settings, every bar, the bounds, the claims and what is missing."""
    return {"experiment": exp.name, "figures": list(exp.figures), "caption": exp.caption, "command": command,
            "episodes": episodes, "seed": seed, "greedy": greedy,
            "results": {group_key(g): row for g, row in data.results.items()},
            "bounds": {group_key(g): b for g, b in data.bounds.items()},
            "claims": [{"claim": v.claim, "ours": v.ours, "agrees": v.agrees} for v in verdicts], "missing": missing}


# -- the sampled full-information bound ------------------------------------------------------------
def optimum_payload(res: dict, env, *, energy: float, max_steps: int, chase_tie: str, seed: int,
                    command: str) -> dict:
    """The JSON record of :func:`jaxdc.dcg.exact.many_items.sampled_bound`'s ``res`` (its per-game rewards
    become a histogram)."""
    res = dict(res)
    rewards = res.pop("rewards")
    return {"optimum": res, "env": repr(env), "energy": unlimited_to_json(energy), "max_steps": max_steps,
            "chase_tie": chase_tie, "seed": seed,
            "reward_histogram": {f"{v:g}": int(c) for v, c in zip(*np.unique(rewards, return_counts=True))},
            "command": command}


def optimum_name(record: dict, episodes: int) -> str:
    """``optimum_<tag>.json``: the tag a digest of the game, its settings, the seed and the number of games."""
    team = record["optimum"].get("collectors", 1)  # a team's bound (jaxdc.dcg.exact.team) names its size
    extra = "" if team == 1 else f"|{team}|{record['optimum']['fog_target']}"
    tag = hashlib.sha1(record["env"].encode() + f"{record['energy']}|{record['max_steps']}|{record['chase_tie']}|"
                       f"{record['seed']}|{episodes}{extra}".encode()).hexdigest()[:8]
    return f"optimum_{tag}.json"


def optimum_text(res: dict, episodes: int) -> str:
    """The one-line summary of the sampled bound."""
    what = "" if res.get("collectors", 1) == 1 else (
        f"{res['collectors']} collectors, " + ("exact" if res["kind"] == "exact" else "upper bound") + ": ")
    return (what + f"full-information bound over {episodes} games: {res['mean']:.3f} +- {res['se']:.3f} (SE), "
            f"SD {res['sd']:.3f}; " + ", ".join(f"{k} {v['mean']:.3f}" for k, v in res["per_strategy"].items())
            + f"; {res['seconds']:.0f} s")
