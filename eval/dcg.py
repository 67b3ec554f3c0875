"""Evaluate trained DCG collectors (section 5.5): reward, RPE, per strategy, opponent accuracy; figures; gameplay.

Examples::

    python -m eval.dcg --net omn_conn --episodes 10000 --json      # a shipped network
    python -m eval.dcg --checkpoint runs/dcg-omn_conn-e15-s0        # a train.dcg run folder (or a .msgpack)
    python -m eval.dcg --net imnn --energy 10 --double-blind
    python -m eval.dcg --net omn_conn --reward-area 1               # Figs. 5.10-5.12, with the exact bound
    python -m eval.dcg figure 5.6                                   # Figs. 5.6/5.7 from the shipped networks
    python -m eval.dcg figure all --episodes 2000
    python -m eval.dcg render --net omn_conn --strategy patrol --seed 3 --greedy --reward-area 2
    python -m eval.dcg optimum --episodes 2000                      # the full-information bound, 10 items

An evaluation writes its JSON atomically to ``--out`` (default
``results/dcg``); ``--json`` prints exactly one JSON object. ``figure``
writes ``results/dcg/figure_<experiment>.{json,csv,md}`` and
``docs/img/dcg_fig<N>.png`` (evaluations are kept in ``runs/eval-cache/dcg/``
and reused for the same parameter file and settings; ``--no-cache``
re-runs them); ``render`` writes a PNG strip (Figs.
5.13-5.15) and a GIF; ``optimum`` estimates the full-information bound of the
standard game over sampled games (``jaxdc.dcg.game_optimum``) and writes
``results/dcg/optimum_<settings>.json``.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import io
import json
import math
import os
import shlex
import sys
import time

from jaxdc.cli.args import positive_float, positive_int
from jaxdc.dcg.opponents import DOUBLE_BLIND_STRATEGIES, STANDARD_STRATEGIES, get_strategies
from jaxdc.io import atomic_write, atomic_write_json, enable_compilation_cache

RESULTS = os.path.join("results", "dcg")
IMAGES = os.path.join("docs", "img")


# -- argument types -----------------------------------------------------------------------------
def _strategies(text):
    try:
        return tuple(s.name for s in get_strategies(text))
    except (TypeError, ValueError) as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _add_network(p, required=True):
    what = p.add_mutually_exclusive_group(required=required)
    what.add_argument("--checkpoint", metavar="PATH", help="a train.dcg run folder or an exported .msgpack")
    what.add_argument("--net", metavar="NAME", help="a shipped network (jaxdc/assets/dcg/NAME.msgpack), "
                      "e.g. vnn, imnn, emnn, omn_conn")


def _add_strategy_set(p, default, default_text):
    sets = p.add_mutually_exclusive_group()
    sets.add_argument("--strategies", type=_strategies, default=default,
                      help=f"comma-separated opponent strategies (default: {default_text})")
    sets.add_argument("--double-blind", action="store_true",
                      help=f"play {','.join(DOUBLE_BLIND_STRATEGIES)} (section 5.5.7, Figs. 5.18-5.19)")


def _add_game(p):
    p.add_argument("--energy", type=positive_float("--energy", allow_inf=True), default=None,
                   help="maximum energy (default: as trained; 10/15/20 in Figs. 5.8-5.9)")
    _add_strategy_set(p, None, "as trained")
    p.add_argument("--reward-area", type=positive_int("--reward-area"), default=None, metavar="S",
                   help="one unit item in the bottom-right S x S square (Figs. 5.10-5.12)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=None,
                   help="step cap (default: as trained, 100)")
    p.add_argument("--greedy", action="store_true", help="argmax policy (default: sample from pi, as the thesis)")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m eval.dcg", description=__doc__.split("\n\n")[0],
                                epilog="subcommands: `figure FIG` (see `python -m eval.dcg figure -h`), "
                                       "`render` (see `python -m eval.dcg render -h`), "
                                       "`optimum` (see `python -m eval.dcg optimum -h`)")
    _add_network(p)
    _add_game(p)
    p.add_argument("--episodes", type=positive_int("--episodes"), default=10_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--rpe-zero", choices=("exclude", "zero"), default="exclude",
                   help="RPE of a game that used no energy: left out (default) or 0")
    p.add_argument("--no-bound", action="store_true", help="with --reward-area: skip the exact bound")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--out", default=RESULTS, help="folder for the result JSON")
    return p


def figure_parser() -> argparse.ArgumentParser:
    from jaxdc.dcg.figures import FIGURES

    p = argparse.ArgumentParser(prog="python -m eval.dcg figure",
                                description="Re-make the thesis' DCG bar charts (Figs. 5.6-5.19) with the "
                                            "thesis' claims beside ours.")
    p.add_argument("figure", choices=sorted(FIGURES, key=lambda f: tuple(map(int, f.split(".")))) + ["all"],
                   help="a thesis figure (its pair is made with it: 5.6 and 5.7 are one experiment)")
    p.add_argument("--episodes", type=positive_int("--episodes"), default=10_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--nets-dir", default=None, help="folder of .msgpack parameter files (default: the shipped ones)")
    p.add_argument("--greedy", action="store_true")
    p.add_argument("--no-bound", action="store_true",
                   help="skip the full-information bound (the exact one of the reward-area figure, the sampled "
                        "one of Figs. 5.6 and 5.16)")
    p.add_argument("--bound-episodes", type=positive_int("--bound-episodes"), default=2000,
                   help="games of PRNGKey(0) the sampled bound of Figs. 5.6 and 5.16 is estimated over (2000; "
                        "docs/dcg.md quotes 10,000)")
    p.add_argument("--cache", default=os.path.join("runs", "eval-cache", "dcg"),
                   help="folder of stored evaluations, reused for the same parameter file and settings")
    p.add_argument("--no-cache", action="store_true", help="re-evaluate every bar")
    p.add_argument("--out", default=RESULTS, help="folder for JSON/CSV/markdown")
    p.add_argument("--img", default=IMAGES, help="folder for the PNGs")
    return p


def render_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m eval.dcg render",
                                description="Play one game and draw it: a PNG strip like Figs. 5.13-5.15 and a GIF.")
    _add_network(p)
    p.add_argument("--strategy", type=_strategies, required=True, help="the opponent strategy, e.g. patrol")
    p.add_argument("--seed", type=int, default=0, help="the game (same seed: same initial state for every network)")
    p.add_argument("--energy", type=positive_float("--energy", allow_inf=True), default=None)
    p.add_argument("--reward-area", type=positive_int("--reward-area"), default=None, metavar="S",
                   help="one unit item in the bottom-right S x S square (as in Figs. 5.13-5.15)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=30,
                   help="steps to play at most (default 30)")
    p.add_argument("--greedy", action="store_true", help="deterministic policy (argmax), as Figs. 5.13-5.15")
    p.add_argument("--cols", type=positive_int("--cols"), default=None, help="frames per row in the strip")
    p.add_argument("--fps", type=positive_int("--fps"), default=4)
    p.add_argument("--out", default=os.path.join(RESULTS, "render"), help="folder for the PNG and GIF")
    return p


def optimum_parser() -> argparse.ArgumentParser:
    from jaxdc.dcg.env import CAPTURES, OPPONENT_STARTS, PATROL_TARGETS
    from jaxdc.dcg.opponents import CHASE_TIES

    p = argparse.ArgumentParser(prog="python -m eval.dcg optimum",
                                description="Estimate the full-information bound of the DCG over sampled games: the "
                                            "most reward any collector could take from each game, knowing the "
                                            "opponent's strategy and hidden state (jaxdc.dcg.game_optimum).")
    p.add_argument("--grid-size", type=positive_int("--grid-size"), default=5, help="N (5 in the thesis)")
    p.add_argument("--total-reward", type=positive_int("--total-reward"), default=10, help="unit rewards dropped")
    p.add_argument("--energy", type=positive_float("--energy", allow_inf=True), default=15.0,
                   help="maximum energy, a whole number or inf (15; 10/20 in Figs. 5.8-5.9)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=100, help="step cap (100)")
    p.add_argument("--chase-tie", choices=CHASE_TIES[:2], default=CHASE_TIES[0],
                   help="tie rule of 'moves towards' (deterministic ones only)")
    _add_strategy_set(p, STANDARD_STRATEGIES, "the standard set of 5.5.1")
    p.add_argument("--opponent-start", choices=OPPONENT_STARTS, default=OPPONENT_STARTS[0])
    p.add_argument("--patrol-target", choices=PATROL_TARGETS, default=PATROL_TARGETS[0])
    p.add_argument("--no-items-on-base", action="store_true", help="the drop leaves the base empty")
    p.add_argument("--no-reward-when-caught", action="store_true",
                   help="an item taken on the step the collector is caught does not count")
    p.add_argument("--capture", choices=CAPTURES, default=CAPTURES[0],
                   help="rule reading: 'opponent_moves' captures only when the opponent moves onto the collector")
    p.add_argument("--safe-base", action="store_true", help="rule reading: no capture in the base")
    p.add_argument("--opponent-out-of-base", action="store_true",
                   help="rule reading: the opponent may not enter the base")
    p.add_argument("--episodes", type=positive_int("--episodes"), default=2000, help="sampled games (2000)")
    p.add_argument("--seed", type=int, default=0, help="the games' PRNG key")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--out", default=RESULTS, help="folder for the result JSON")
    return p


# -- loading ------------------------------------------------------------------------------------
def load_learned(args):
    from jaxdc.dcg import learned

    if args.checkpoint:
        return learned.load(args.checkpoint)
    return learned.shipped(args.net)


def strategy_set(args):
    if getattr(args, "double_blind", False):
        return DOUBLE_BLIND_STRATEGIES
    return args.strategies


_BOUNDS: dict = {}


def bound_for(env, params):
    """The exact full-information bound (``jaxdc.dcg.optimal``) of a reward-area game, or ``None`` without the solver.

    Solved once per game (environment and numeric settings) in a process.
    """
    try:
        from jaxdc.dcg.optimal import full_information_bound
    except ImportError:
        return None
    key = (env, float(params.max_energy), int(params.max_steps), int(params.chase_tie))
    if key not in _BOUNDS:
        _BOUNDS[key] = full_information_bound(env, params)
    return _BOUNDS[key]


# -- one evaluation -----------------------------------------------------------------------------
def evaluate(learned, *, episodes, seed, energy=None, strategies=None, reward_area=None, max_steps=None,
             greedy=False, rpe_zero="exclude", bound=True) -> dict:
    """The section-5.5 statistics of ``learned`` in its game with the given changes, as one JSON-able dict."""
    import jax

    from jaxdc.dcg.evaluate import evaluate_network, summarize

    env, params = learned.game(energy=energy, strategies=strategies, reward_area=reward_area, max_steps=max_steps)
    t0 = time.perf_counter()
    final = evaluate_network(env, params, learned.net, learned.params, jax.random.PRNGKey(seed), episodes, greedy)
    jax.block_until_ready(final)
    out = summarize(final, env.strategies, rpe_zero)
    out["seconds"] = round(time.perf_counter() - t0, 3)
    out["net"] = learned.net_name
    out["alpha"] = learned.metadata.get("alpha")
    out["source"] = os.path.relpath(learned.source) if os.path.exists(learned.source) else learned.source
    out["setting"] = {"grid_size": env.grid_size, "total_reward": env.total_reward,
                      "energy": float(params.max_energy), "max_steps": int(params.max_steps),
                      "strategies": list(env.strategies), "reward_area": reward_area,
                      "history": learned.setting()["history"], "trained_steps": learned.steps}
    out["seed"], out["greedy"] = seed, bool(greedy)
    if reward_area is not None and bound:
        b = bound_for(env, params)
        if b is not None:
            out["bound"] = {"total": b["total"], "per_strategy": b["per_strategy"]}
            out["fraction_of_bound"] = out["reward"]["mean"] / b["total"] if b["total"] > 0 else None
            for name, s in out["per_strategy"].items():
                v = b["per_strategy"].get(name)
                s["fraction_of_bound"] = s["reward"]["mean"] / v if v else None
    return out


def result_name(r: dict) -> str:
    s = r["setting"]
    sets = "standard" if tuple(s["strategies"]) == STANDARD_STRATEGIES else (
        "double_blind" if tuple(s["strategies"]) == DOUBLE_BLIND_STRATEGIES else "-".join(s["strategies"]))
    parts = [f"eval_{r['net']}"]
    if r["net"] == "emnn" and r.get("alpha") is not None:
        parts.append(f"a{r['alpha']:g}")
    parts += [f"e{s['energy']:g}", sets]
    if s["reward_area"] is not None:
        parts.append(f"area{s['reward_area']}")
    if r["greedy"]:
        parts.append("greedy")
    parts.append(f"s{r['seed']}")
    return "_".join(parts) + ".json"


def _line(r: dict) -> str:
    acc = r["opponent_accuracy"]
    text = (f"reward {r['reward']['mean']:.3f} ± {r['reward']['sd']:.3f}   RPE {r['rpe']['mean']:.4f} ± "
            f"{r['rpe']['sd']:.4f}   steps {r['steps']['mean']:.1f}")
    if acc is not None:
        text += f"   opponent accuracy {100 * acc:.1f}%"
    if r.get("fraction_of_bound") is not None:
        text += f"   {100 * r['fraction_of_bound']:.1f}% of the bound {r['bound']['total']:.4f}"
    return text


def report(r: dict) -> str:
    """The text report of one evaluation: totals, outcomes and one line per strategy."""
    lines = [f"all ({r['episodes']} games)".ljust(24) + _line(r),
             "outcomes: " + ", ".join(f"{k} {v}" for k, v in r["outcomes"].items())]
    for name, s in r["per_strategy"].items():
        lines.append(f"{name} ({s['episodes']})".ljust(24) + _line(s))
    return "\n".join(lines)


def cmd_evaluate(argv) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    enable_compilation_cache()
    try:
        learned = load_learned(args)
        if not args.json:
            print(f"Evaluating {learned.describe()}: {args.episodes} games, seed {args.seed} ...", file=sys.stderr)
        r = evaluate(learned, episodes=args.episodes, seed=args.seed, energy=args.energy,
                     strategies=strategy_set(args), reward_area=args.reward_area, max_steps=args.max_steps,
                     greedy=args.greedy, rpe_zero=args.rpe_zero, bound=not args.no_bound)
    except (TypeError, ValueError) as e:
        parser.error(str(e))
    r["command"] = "python -m eval.dcg " + shlex.join(argv)
    path = atomic_write_json(os.path.join(args.out, result_name(r)), r)
    if args.json:
        print(json.dumps(r))
    else:
        print(report(r))
        print(f"written to {path}", file=sys.stderr)
    return 0


# -- figures ------------------------------------------------------------------------------------
def _pool(nets_dir):
    """``{name: metadata}`` of the DCG parameter files in ``nets_dir`` (default: the shipped ones), and the folder."""
    from jaxdc import pretrained

    folder = nets_dir or os.path.join(pretrained.ASSETS, "dcg")
    if not os.path.isdir(folder):
        if nets_dir:
            raise ValueError(f"--nets-dir: no such folder {nets_dir!r}")
        return {}, folder
    pool = {}
    for f in sorted(os.listdir(folder)):
        if f.endswith(".msgpack"):
            meta = pretrained.read_metadata(os.path.join(folder, f))
            if meta.get("problem") == "dcg":
                pool[f[: -len(".msgpack")]] = meta
    return pool, folder


def _group_key(g) -> str:
    return "all" if g is None else f"{g:g}"


def run_experiment(exp, pool, folder, args, progress=print) -> dict:
    """Evaluate every bar of ``exp``; ``{group: {label: result}}`` plus the bound per reward area."""
    from jaxdc.dcg import learned as learned_lib
    from jaxdc.dcg.figures import select

    results, bounds, notes = {}, {}, {}
    cache = {}
    for g in exp.groups:
        results[g] = {}
        for entry in select(pool, exp, g):
            settings = dict(episodes=args.episodes, seed=args.seed, energy=entry.energy, strategies=entry.strategies,
                            reward_area=entry.reward_area, greedy=args.greedy, bound=not args.no_bound)
            r = _cached(os.path.join(folder, entry.name + ".msgpack"), settings, args)
            if r is None:
                if entry.name not in cache:
                    cache[entry.name] = learned_lib.load(os.path.join(folder, entry.name + ".msgpack"))
                r = evaluate(cache[entry.name], **settings)
                _store(os.path.join(folder, entry.name + ".msgpack"), settings, args, r)
            r["file"] = entry.name
            r["note"] = entry.note
            results[g][entry.label] = r
            if "bound" in r:
                bounds[g] = r["bound"]
            if entry.note:
                notes[entry.label] = entry.note
            progress(f"  {exp.group_name + ' ' + _group_key(g) if g is not None else exp.name}: {entry.label:16s} "
                     f"reward {r['reward']['mean']:.3f}  RPE {r['rpe']['mean']:.4f}  ({r['seconds']:.1f} s)")
    if exp.game_bound and not args.no_bound and results.get(None):
        first = next(iter(results[None].values()))["file"]
        learned = cache.get(first) or learned_lib.load(os.path.join(folder, first + ".msgpack"))
        b = game_bound(learned, args)
        if b is not None:
            bounds[None] = b
            progress(f"  {exp.name}: full-information bound {b['total']:.3f} ± {b['se']:.3f} "
                     f"({b['episodes']} games)")
            for r in results[None].values():
                r["fraction_of_bound"] = r["reward"]["mean"] / b["total"] if b["total"] > 0 else None
    return {"results": results, "bounds": bounds, "notes": notes}


def game_bound(learned, args) -> dict | None:
    """The sampled full-information bound (:func:`jaxdc.dcg.game_optimum.sampled_bound`) of the game ``learned``
    was trained on, over ``args.bound_episodes`` games of ``PRNGKey(0)``; stored in ``args.cache`` per game.
    ``None`` where the search does not apply to the game (``NotImplementedError``)."""
    import jax

    from jaxdc.dcg.game_optimum import sampled_bound

    env, params = learned.game()
    game = {"env": repr(env), "energy": float(params.max_energy), "max_steps": int(params.max_steps),
            "chase_tie": int(params.chase_tie), "episodes": args.bound_episodes, "key": 0}
    stored = _cached(None, game, args)
    if stored is not None:
        return stored
    try:
        res = sampled_bound(env, params, jax.random.PRNGKey(0), args.bound_episodes)
    except NotImplementedError:
        return None
    out = {"total": res["mean"], "se": res["se"], "episodes": res["episodes"],
           "per_strategy": {k: v["mean"] for k, v in res["per_strategy"].items()}, "game": game}
    _store(None, game, args, out)
    return out


def _figure(width):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt, *plt.subplots(figsize=(width, 3.8))


def _save(plt, fig, path):
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return atomic_write(path, buf.getvalue())


def _cache_path(blob, settings, args):
    """``CACHE/<sha256>.json``: one evaluation of one parameter file (its bytes and metadata) with one set of
    settings; ``blob=None``: a result of the settings alone (the game bound, ``bound_<sha256>.json``)."""
    digest = hashlib.sha256()
    for path in () if blob is None else (blob, blob[: -len(".msgpack")] + ".json"):
        with open(path, "rb") as f:
            digest.update(f.read())
    digest.update(json.dumps(settings, sort_keys=True, default=list).encode())
    return os.path.join(args.cache, ("bound_" if blob is None else "") + digest.hexdigest()[:24] + ".json")


def _cached(blob, settings, args):
    """A stored evaluation of the same file with the same settings (``--no-cache`` ignores it)."""
    path = _cache_path(blob, settings, args)
    if args.no_cache or not os.path.isfile(path):
        return None
    with open(path) as f:
        return json.load(f)


def _store(blob, settings, args, result):
    atomic_write_json(_cache_path(blob, settings, args), result)


def _plot(exp, results, bounds, col, path, title):
    """A bar chart like the thesis' (mean with SD error bars, labelled); one bar group per energy/area."""
    groups = list(exp.groups)
    labels = []
    for g in groups:
        labels += [lb for lb in results[g] if lb not in labels]
    single = len(groups) == 1
    plt, fig, ax = _figure(max(5.0, 1.1 * len(labels)) if single else max(6.0, 0.55 * len(labels) * len(groups) + 2))
    width = 0.7 if single else 0.8 / max(len(labels), 1)
    colors = plt.get_cmap("tab10").colors
    fmt = "%.3f" if col == "rpe" else "%.2f"
    for j, lb in enumerate(labels):
        xs, ys, es = [], [], []
        for i, g in enumerate(groups):
            r = results[g].get(lb)
            if r is not None:
                xs.append(j if single else i + (j - (len(labels) - 1) / 2) * width)
                ys.append(r[col]["mean"])
                es.append(r[col]["sd"])
        bars = ax.bar(xs, ys, width, yerr=es, capsize=3, label=lb, color=colors[j % 10])
        ax.bar_label(bars, fmt=fmt, fontsize=7, padding=2)
    if col == "reward" and bounds:
        for i, g in enumerate(groups):
            if g in bounds:
                lo, hi = (-0.45, len(labels) - 0.55) if single else (i - 0.45, i + 0.45)
                ax.hlines(bounds[g]["total"], lo, hi, colors="k", linestyles="--",
                          label="full-information bound" if i == 0 else None)
                if single:
                    ax.text(hi, bounds[g]["total"], f"full-information bound {bounds[g]['total']:.2f}",
                            ha="right", va="bottom", fontsize=7)
    if single:
        ax.set_xticks(range(len(labels)), [lb.replace(" strong", "\nstrong") for lb in labels], fontsize=8)
    else:
        ax.set_xticks(range(len(groups)), [f"{exp.group_name} {_group_key(g)}" for g in groups])
        ax.legend(fontsize=7, ncol=min(len(labels) + 1, 3))
    ax.set_ylabel("episode reward" if col == "reward" else "reward per energy")
    ax.set_ylim(bottom=0)
    ax.set_title(title, fontsize=9)
    return _save(plt, fig, path)


def _plot_strategies(results, path, title):
    """Per-strategy episode reward of each network (ours; the thesis gives no such chart)."""
    labels = list(results)
    if not labels:
        return None
    strategies = list(results[labels[0]]["per_strategy"])
    plt, fig, ax = _figure(max(6.0, 0.55 * len(labels) * len(strategies) + 2))
    width = 0.8 / len(labels)
    colors = plt.get_cmap("tab10").colors
    for j, lb in enumerate(labels):
        xs = [i + (j - (len(labels) - 1) / 2) * width for i in range(len(strategies))]
        ps = results[lb]["per_strategy"]
        bars = ax.bar(xs, [ps[s]["reward"]["mean"] for s in strategies], width,
                      yerr=[ps[s]["reward"]["sd"] for s in strategies], capsize=3, label=lb, color=colors[j % 10])
        ax.bar_label(bars, fmt="%.2f", fontsize=7, padding=2)
    ax.set_xticks(range(len(strategies)), strategies)
    ax.set_ylabel("episode reward")
    ax.set_ylim(bottom=0)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, ncol=min(len(labels), 3))
    return _save(plt, fig, path)


def _csv(exp, results) -> str:
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["group", "network", "strategy", "episodes", "reward_mean", "reward_sd", "rpe_mean", "rpe_sd",
                "energy_mean", "steps_mean", "opponent_accuracy", "fraction_of_bound", "file", "note"])
    for g, row in results.items():
        for lb, r in row.items():
            for strat, s in [("all", r)] + list(r["per_strategy"].items()):
                w.writerow([_group_key(g), lb, strat, s["episodes"], s["reward"]["mean"], s["reward"]["sd"],
                            s["rpe"]["mean"], s["rpe"]["sd"], s["energy"]["mean"], s["steps"]["mean"],
                            s.get("opponent_accuracy"), s.get("fraction_of_bound"), r["file"], r["note"]])
    return buf.getvalue()


def _markdown(exp, data, claims_rows, missing, command, images) -> str:
    results = data["results"]
    lines = [f"### Figs. {' and '.join(exp.figures)}: {exp.caption}", "", f"`{command}`", ""]
    for img in images:
        lines.append(f"![{os.path.basename(img)}]({img})")
    lines += ["", "| " + (exp.group_name + " | " if exp.group_name else "") +
              "network | reward | RPE | opponent accuracy | " + ("bound / fraction | " if data["bounds"] else "")
              + " | ".join(f"{s} reward" for s in exp.strategies) + " | note |",
              "|" + "---|" * (5 + bool(exp.group_name) + bool(data["bounds"]) + len(exp.strategies))]
    for g, row in results.items():
        for lb, r in row.items():
            acc = r["opponent_accuracy"]
            cells = ([_group_key(g)] if exp.group_name else []) + [
                lb, f"{r['reward']['mean']:.3f} ± {r['reward']['sd']:.3f}",
                f"{r['rpe']['mean']:.4f} ± {r['rpe']['sd']:.4f}", "—" if acc is None else f"{100 * acc:.1f}%"]
            if data["bounds"]:
                b = data["bounds"].get(g)
                fr = r.get("fraction_of_bound")
                cells.append("—" if b is None else f"{b['total']:.4f} / " + ("—" if fr is None else f"{100 * fr:.1f}%"))
            cells += [f"{r['per_strategy'][s]['reward']['mean']:.3f}" if s in r["per_strategy"] else "—"
                      for s in exp.strategies]
            cells.append(r["note"] or "")
            lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "| thesis claim | ours | agrees |", "|---|---|---|"]
    lines += [f"| {c} | {o} | {a} |" for c, o, a in claims_rows]
    if missing:
        lines += ["", "Missing networks (no parameter file trained as the thesis did): " + "; ".join(missing) + "."]
    return "\n".join(lines) + "\n"


def _load_standard(out):
    path = os.path.join(out, "figure_standard.json")
    if not os.path.isfile(path):
        return None
    with open(path) as f:
        data = json.load(f)
    return {None: data["results"].get("all", {})}


def cmd_figure(argv) -> int:
    from jaxdc.dcg.figures import EXPERIMENTS, FIGURES, claims, missing

    parser = figure_parser()
    args = parser.parse_args(argv)
    enable_compilation_cache()
    names = list(EXPERIMENTS) if args.figure == "all" else [FIGURES[args.figure]]
    command = "python -m eval.dcg figure " + shlex.join(argv)
    try:
        pool, folder = _pool(args.nets_dir)
        if not pool:
            raise ValueError(f"no DCG parameter files in {folder}: train them with `python -m train.dcg --net NET "
                             "--ship` (or pass --nets-dir)")
        for name in names:
            exp = EXPERIMENTS[name]
            print(f"Figs. {'/'.join(exp.figures)} ({exp.caption}): {args.episodes} games per bar", file=sys.stderr)
            data = run_experiment(exp, pool, folder, args, progress=lambda s: print(s, file=sys.stderr))
            gone = missing(pool, exp)
            if not any(data["results"].values()):
                print(f"  no network for this experiment; missing: {'; '.join(gone)}", file=sys.stderr)
                continue
            standard = _load_standard(args.out) if name == "double_blind" else None
            rows = claims(exp, data["results"], standard)
            images = []
            for fig_no, col in zip(exp.figures, ("reward", "rpe")):
                path = os.path.join(args.img, f"dcg_fig{fig_no.replace('.', '_')}.png")
                title = f"Fig. {fig_no} (ours): {'episode reward' if col == 'reward' else 'RPE'}\n{exp.caption}"
                images.append(_plot(exp, data["results"], data["bounds"], col, path, title))
            if name in ("standard", "double_blind", "standard_5m"):
                path = os.path.join(args.img, f"dcg_{name}_per_strategy.png")
                p = _plot_strategies(data["results"][None], path, f"Episode reward per opponent strategy (ours)\n{exp.caption}")
                if p:
                    images.append(p)
            rel = [os.path.relpath(p, args.out) for p in images]
            payload = {"experiment": name, "figures": list(exp.figures), "caption": exp.caption, "command": command,
                       "episodes": args.episodes, "seed": args.seed, "greedy": args.greedy,
                       "results": {_group_key(g): row for g, row in data["results"].items()},
                       "bounds": {_group_key(g): b for g, b in data["bounds"].items()},
                       "claims": [{"claim": c, "ours": o, "agrees": a} for c, o, a in rows], "missing": gone}
            atomic_write_json(os.path.join(args.out, f"figure_{name}.json"), payload)
            atomic_write(os.path.join(args.out, f"figure_{name}.csv"), _csv(exp, data["results"]))
            md = _markdown(exp, data, rows, gone, command, rel)
            atomic_write(os.path.join(args.out, f"figure_{name}.md"), md)
            print(md)
    except (TypeError, ValueError) as e:
        parser.error(str(e))
    return 0


# -- gameplay -----------------------------------------------------------------------------------
def cmd_render(argv) -> int:
    parser = render_parser()
    args = parser.parse_args(argv)
    if len(args.strategy) != 1:
        parser.error(f"--strategy takes one strategy, got {','.join(args.strategy)}")
    enable_compilation_cache()
    try:
        import jax

        from jaxdc.core.trajectory import play_episode

        learned = load_learned(args)
        env, params = learned.game(energy=args.energy, strategies=args.strategy, reward_area=args.reward_area,
                                   max_steps=args.max_steps)
        states = play_episode(env, params, learned.policy(args.greedy), jax.random.PRNGKey(args.seed),
                              args.max_steps)
    except (TypeError, ValueError) as e:
        parser.error(str(e))
    from jaxdc import viewer

    last = states[-1]
    from jaxdc.dcg.env import OUTCOMES

    stem = (f"dcg_{learned.net_name}_{args.strategy[0]}_s{args.seed}" + ("_greedy" if args.greedy else "")
            + (f"_area{args.reward_area}" if args.reward_area else ""))
    strip = viewer.save_strip(env, params, states, os.path.join(args.out, stem + ".png"), cols=args.cols)
    gif = viewer.save_animation(env, params, states, os.path.join(args.out, stem + ".gif"), fps=args.fps)
    print(f"{learned.net_name} vs {args.strategy[0]}, seed {args.seed}: {len(states) - 1} steps, "
          f"reward {float(last.ep_reward):g}, outcome {OUTCOMES[int(last.outcome)]}")
    print(f"written {strip} and {gif}")
    return 0


# -- the full-information bound of the standard game --------------------------------------------------
def cmd_optimum(argv) -> int:
    parser = optimum_parser()
    args = parser.parse_args(argv)
    if not (math.isinf(args.energy) or args.energy == math.floor(args.energy)):
        parser.error(f"--energy must be a whole number or inf for the exact bound, got {args.energy:g}")
    try:
        import jax
        import numpy as np

        from jaxdc.dcg import DCG
        from jaxdc.dcg.game_optimum import sampled_bound

        env = DCG(grid_size=args.grid_size, total_reward=args.total_reward, history=1, obs_history=False,
                  strategies=strategy_set(args), opponent_start=args.opponent_start, patrol_target=args.patrol_target,
                  items_on_base=not args.no_items_on_base, reward_when_caught=not args.no_reward_when_caught,
                  capture=args.capture, safe_base=args.safe_base, opponent_enters_base=not args.opponent_out_of_base)
        params = env.make_params(energy=args.energy, max_steps=args.max_steps, chase_tie=args.chase_tie)
        res = sampled_bound(env, params, jax.random.PRNGKey(args.seed), args.episodes,
                            progress=not args.no_progress)
    except (TypeError, ValueError, NotImplementedError) as e:
        parser.error(str(e))
    rewards = res.pop("rewards")
    out = {"optimum": res, "env": repr(env), "energy": args.energy, "max_steps": args.max_steps,
           "chase_tie": args.chase_tie, "seed": args.seed,
           "reward_histogram": {f"{v:g}": int(c) for v, c in zip(*np.unique(rewards, return_counts=True))},
           "command": "python -m eval.dcg optimum " + shlex.join(argv)}
    tag = hashlib.sha1(out["env"].encode() + f"{args.energy}|{args.max_steps}|{args.chase_tie}|{args.seed}|"
                       f"{args.episodes}".encode()).hexdigest()[:8]
    path = os.path.join(args.out, f"optimum_{tag}.json")
    atomic_write_json(path, out)
    if args.json:
        print(json.dumps(out))
    else:
        print(f"full-information bound over {args.episodes} games: {res['mean']:.3f} +- {res['se']:.3f} (SE), "
              f"SD {res['sd']:.3f}; " + ", ".join(f"{k} {v['mean']:.3f}" for k, v in res["per_strategy"].items())
              + f"; {res['seconds']:.0f} s")
        print(f"written {path}")
    return 0


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "figure":
        return cmd_figure(argv[1:])
    if argv and argv[0] == "render":
        return cmd_render(argv[1:])
    if argv and argv[0] == "optimum":
        return cmd_optimum(argv[1:])
    return cmd_evaluate(argv)


if __name__ == "__main__":
    sys.exit(main())
