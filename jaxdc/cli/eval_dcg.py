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
    python -m eval.dcg energies --checkpoint NET --energies 8 10 12 15 20 25   # one collector per energy
    python -m eval.dcg --net omn_conn_strong --collectors 2          # two copies in the team game

An evaluation writes its JSON atomically to ``--out`` (default
``results/dcg``); ``--json`` prints exactly one JSON object. Every JSON is
strict: unlimited energy is ``"inf"``, an undefined statistic (the RPE of games
that consumed no energy) is ``null`` beside its reason, and the text reports
print it as ``—``. ``figure``
writes ``results/dcg/figure_<experiment>.{json,csv,md}`` and
``docs/img/dcg_fig<N>.png`` (evaluations are kept in ``runs/eval-cache/dcg/``
and reused for the same parameter file and settings; ``--no-cache``
re-runs them); ``render`` writes a PNG strip (Figs.
5.13-5.15) and a GIF; ``optimum`` estimates the full-information bound of the
standard game over sampled games (``jaxdc.dcg.exact.many_items``) and writes
``results/dcg/optimum_<settings>.json``; ``energies`` plays one collector (e.g.
one trained with ``train.dcg --energy-range``) at each maximum energy beside
that bound and the shipped per-energy collectors of Figs. 5.8-5.9
(``jaxdc.dcg.analysis.energies``) and writes
``results/dcg/energies_<name>_s<seed>.{json,md}`` (``<name>``: the network as given).

Every flag value is checked before any work (numbers finite and in range,
seeds in ``0 .. 2**32 - 1``, output folders creatable and writable); a bad one
exits 2 with one line naming the flag. The files of one result (a figure's
JSON, CSV, markdown and PNGs; a render's PNG and GIF) land together, and Ctrl-C
exits 130 leaving the previous files or the complete new set.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys

import jax

from jaxdc import pretrained
from jaxdc.cli import eval_dcg_energies as energies
from jaxdc.cli import eval_dcg_optimum as optimum
from jaxdc.cli import runner
from jaxdc.cli.args import check_run_seed, integer, positive_float, positive_int, seed
from jaxdc.cli.eval_dcg_settings import EvaluateSettings, FigureSettings, RenderSettings
from jaxdc.cli.runner import run
from jaxdc.core.energy import MAX_FINITE_ENERGY
from jaxdc.core.masks import MASKS
from jaxdc.core.trajectory import play_episode
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis.claims import claims
from jaxdc.dcg.analysis.collector_eval import evaluate
from jaxdc.dcg.analysis.experiment import group_key, network_pool, run_experiment, stored_standard
from jaxdc.dcg.analysis.figures import EXPERIMENTS, FIGURES, missing
from jaxdc.dcg.analysis.report import (
    figure_csv,
    figure_markdown,
    figure_payload,
    report,
    result_name,
    source_stem,
    team_report,
    team_result_name,
)
from jaxdc.dcg.analysis.team import evaluate_learned as evaluate_learned_team
from jaxdc.dcg.env import OUTCOMES
from jaxdc.dcg.opponents import DOUBLE_BLIND_STRATEGIES, get_strategies
from jaxdc.dcg.team.policies import copies
from jaxdc.dcg.team.state import MAX_COLLECTORS
from jaxdc.io import (
    atomic_write_json,
    atomic_write_set,
    check_output_folder,
    check_output_path,
    enable_compilation_cache,
    json_text,
    unlimited_to_json,
)
from jaxdc.provenance import provenance
from jaxdc.viewer.bars import bar_chart_png, strategy_chart_png
from jaxdc.viewer.media import animation_bytes, check_animation, strip_png

PROG = "python -m eval.dcg"
RESULTS = os.path.join("results", "dcg")
IMAGES = os.path.join("docs", "img")
#: The subcommands; a command line that does not start with one of them is an ``evaluate``.
SUBCOMMANDS = ("evaluate", "figure", "render", "optimum", "energies")
DEFAULT_SUBCOMMAND = "evaluate"
#: Most frames per row of a ``render`` strip.
MAX_COLS = 1000
#: Most frames per second of a ``render`` animation.
MAX_FPS = 60
#: Most steps a ``render`` plays (every step is a drawn frame).
MAX_RENDER_STEPS = 1000


# -- argument types and groups ------------------------------------------------------------------
def _strategies(text):
    try:
        return tuple(s.name for s in get_strategies(text))
    except (TypeError, ValueError) as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _add_network(p, required=True):
    what = p.add_mutually_exclusive_group(required=required)
    what.add_argument("--checkpoint", metavar="PATH|NAME",
                      help="a train.dcg run folder, an exported .msgpack or a shipped network's name")
    what.add_argument("--net", metavar="NAME", help="a shipped network (jaxdc/assets/dcg/NAME.msgpack), "
                      "e.g. vnn, imnn, emnn, omn_conn")
    p.add_argument("--run-seed", type=seed("--run-seed"), default=None, metavar="S",
                   help="--checkpoint of a train.dcg --seeds run: the seed whose network to play")


def _add_strategy_set(p, default, default_text):
    sets = p.add_mutually_exclusive_group()
    sets.add_argument("--strategies", type=_strategies, default=default,
                      help=f"comma-separated opponent strategies (default: {default_text})")
    sets.add_argument("--double-blind", action="store_true",
                      help=f"play {','.join(DOUBLE_BLIND_STRATEGIES)} (section 5.5.7, Figs. 5.18-5.19)")


def _energy():
    return positive_float("--energy", allow_inf=True, high=MAX_FINITE_ENERGY)


def _add_game(p):
    p.add_argument("--energy", type=_energy(), default=None,
                   help="maximum energy (default: as trained; 10/15/20 in Figs. 5.8-5.9)")
    _add_strategy_set(p, None, "as trained")
    p.add_argument("--reward-area", type=positive_int("--reward-area"), default=None, metavar="S",
                   help="one unit item in the bottom-right S x S square (Figs. 5.10-5.12)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=None,
                   help="step cap (default: as trained, 100)")
    p.add_argument("--greedy", action="store_true", help="argmax policy (default: sample from pi, as the thesis)")


def _add_mask(p):
    p.add_argument("--mask", choices=MASKS, default=None,
                   help="play one collector under an action mask (beyond the thesis): reach_base, a move must leave "
                        "the energy to get home; reach_base_or_item, or to reach an item, or it takes one; none, "
                        "the thesis' policy (default: the mask the network was trained under, none for the thesis')")


def _figure_order(fig: str):
    return tuple(map(int, fig.split(".")))


# -- the parser ---------------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    """The parser of ``python -m eval.dcg``: the subcommands ``evaluate`` (the default), ``figure``, ``render``
    and ``optimum``; :func:`main` puts ``evaluate`` in front of a command line without a subcommand."""
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="{" + ",".join(SUBCOMMANDS) + "}")

    p = sub.add_parser("evaluate", prog=PROG, description=__doc__.split("\n\n")[0],
                       help="evaluate one collector (the default)",
                       epilog="subcommands: `figure FIG` (see `python -m eval.dcg figure -h`), "
                              "`render` (see `python -m eval.dcg render -h`), "
                              "`optimum` (see `python -m eval.dcg optimum -h`)")
    _add_network(p)
    _add_game(p)
    p.add_argument("--episodes", type=positive_int("--episodes"), default=10_000)
    p.add_argument("--seed", type=seed("--seed"), default=0)
    p.add_argument("--rpe-zero", choices=("exclude", "zero"), default="exclude",
                   help="RPE of a game that used no energy: left out (default) or 0")
    p.add_argument("--no-bound", action="store_true", help="with --reward-area: skip the exact bound")
    _add_mask(p)
    p.add_argument("--collectors", type=integer("--collectors", low=1, high=MAX_COLLECTORS), default=None,
                   help="play the team game (beyond the thesis): a one-collector network as K copies; a network "
                        "trained as a team plays its own size (the default)")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--out", default=RESULTS, help="folder for the result JSON")
    p.set_defaults(run=_evaluate, error=p.error)

    p = sub.add_parser("figure", prog=f"{PROG} figure", help="re-make a thesis figure",
                       description="Re-make the thesis' DCG bar charts (Figs. 5.6-5.19) with the "
                                   "thesis' claims beside ours.")
    p.add_argument("figure", choices=sorted(FIGURES, key=_figure_order) + ["all"],
                   help="a thesis figure (its pair is made with it: 5.6 and 5.7 are one experiment)")
    p.add_argument("--episodes", type=positive_int("--episodes"), default=10_000)
    p.add_argument("--seed", type=seed("--seed"), default=0)
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
    p.set_defaults(run=_figure, error=p.error)

    p = sub.add_parser("render", prog=f"{PROG} render", help="play one game and draw it",
                       description="Play one game and draw it: a PNG strip like Figs. 5.13-5.15 and a GIF.")
    _add_network(p)
    p.add_argument("--strategy", type=_strategies, required=True, help="the opponent strategy, e.g. patrol")
    p.add_argument("--seed", type=seed("--seed"), default=0,
                   help="the game (same seed: same initial state for every network)")
    p.add_argument("--energy", type=_energy(), default=None)
    p.add_argument("--reward-area", type=positive_int("--reward-area"), default=None, metavar="S",
                   help="one unit item in the bottom-right S x S square (as in Figs. 5.13-5.15)")
    p.add_argument("--max-steps", type=positive_int("--max-steps", high=MAX_RENDER_STEPS), default=30,
                   help=f"steps to play at most, one frame each (default 30, at most {MAX_RENDER_STEPS})")
    p.add_argument("--greedy", action="store_true", help="deterministic policy (argmax), as Figs. 5.13-5.15")
    p.add_argument("--cols", type=positive_int("--cols", high=MAX_COLS), default=None,
                   help="frames per row in the strip")
    p.add_argument("--fps", type=positive_int("--fps", high=MAX_FPS), default=4,
                   help=f"frames per second of the GIF (1..{MAX_FPS}; default 4)")
    p.add_argument("--out", default=os.path.join(RESULTS, "render"), help="folder for the PNG and GIF")
    p.set_defaults(run=_render, error=p.error)

    optimum.add_parser(sub, PROG, RESULTS, _energy, _add_strategy_set)
    energies.add_parser(sub, PROG, _add_network, RESULTS, _add_mask)
    return parser


def _load(checkpoint, net, run_seed=None):
    check_run_seed(run_seed, checkpoint, "train.dcg")
    return learned_lib.load(checkpoint, run_seed=run_seed) if checkpoint else learned_lib.shipped(net)


# -- the subcommands ----------------------------------------------------------------------------
def _check_folders(args, *flags, files: dict | None = None, inputs: dict | None = None):
    """Refuse, before any work, an output folder (``--out`` ...) that cannot be created or written, or whose
    ``files[flag]`` (the names written into it) would overwrite one of the command's ``inputs``."""
    for flag in flags:
        try:
            check_output_folder(getattr(args, flag.lstrip("-").replace("-", "_")), flag,
                                files=(files or {}).get(flag, ()), inputs=inputs)
        except ValueError as e:
            args.error(str(e))


def _checkpoint_inputs(args) -> dict:
    """The files ``--checkpoint`` reads (for the check that no output overwrites them)."""
    return {"--checkpoint": pretrained.read_paths(args.checkpoint, "dcg") if args.checkpoint else None}


def _nets_dir_inputs(nets_dir: str | None) -> dict:
    """The parameter files of ``--nets-dir`` (each ``.msgpack`` and its ``.json``)."""
    if not nets_dir or not os.path.isdir(nets_dir):
        return {}
    return {"--nets-dir": [os.path.join(nets_dir, f) for f in sorted(os.listdir(nets_dir))
                           if f.endswith((".msgpack", ".json"))]}


def _figure_files(names) -> dict:
    """``{flag: names}`` of the files ``figure`` writes for the experiments ``names``."""
    out, img = [], []
    for name in names:
        exp = EXPERIMENTS[name]
        out += [f"figure_{name}.{ext}" for ext in ("json", "csv", "md")]
        img += [f"dcg_fig{no.replace('.', '_')}.png" for no in exp.figures]
        img += [f"dcg_{name}_per_strategy.png"] if exp.per_strategy_chart else []
    return {"--out": out, "--img": img}


def _evaluate(args, command) -> int:
    _check_folders(args, "--out")
    s = EvaluateSettings.from_args(args)
    enable_compilation_cache()
    try:
        learned = _load(s.checkpoint, s.net, s.run_seed)
        team = s.collectors is not None or learned.collectors > 1
        if team and s.reward_area is not None:
            raise ValueError("--reward-area plays the one-collector game of Figs. 5.10-5.12; a team (--collectors, "
                             "or a network trained as a team) plays the standard game")
        if team and s.mask not in (None, "none"):
            raise ValueError(f"--mask {s.mask} plays one collector; a team (--collectors, or a network trained "
                             "as a team) plays without one")
        # the result's name depends only on the network and the settings: check the file before any game
        expected = check_output_path(_result_path(s, learned, team), "--out file", _checkpoint_inputs(args))
        if not s.json:
            print(f"Evaluating {learned.describe()}: {s.episodes} games, seed {s.seed} ...", file=sys.stderr)
        with runner.progress(PROG, s.max_steps):  # a huge --max-steps: a line a minute while it plays
            if team:
                r = evaluate_learned_team(learned, s.collectors, episodes=s.episodes, seed=s.seed, greedy=s.greedy,
                                          energy=s.energy, strategies=s.strategies, max_steps=s.max_steps)
            else:
                r = evaluate(learned, episodes=s.episodes, seed=s.seed, energy=s.energy, strategies=s.strategies,
                             reward_area=s.reward_area, max_steps=s.max_steps, greedy=s.greedy,
                             rpe_zero=s.rpe_zero, bound=s.bound, mask=s.mask)
    except (TypeError, ValueError) as e:
        args.error(str(e))
    r["command"] = command
    if s.run_seed is not None:
        r["run_seed"] = s.run_seed
    line = json_text(r, indent=None)  # strict: refused before anything is written
    target = os.path.join(s.out, team_result_name(r) if team else result_name(r))
    if target != expected:  # the name checked is the one the results give; should they ever differ, check it too
        try:
            target = check_output_path(target, "--out file", _checkpoint_inputs(args))
        except ValueError as e:
            args.error(str(e))
    path = atomic_write_json(target, {**r, "provenance": provenance()})
    if s.json:
        print(line)
    else:
        print(team_report(r) if team else report(r))
        print(f"written to {path}", file=sys.stderr)
    return 0


def _result_path(s: EvaluateSettings, learned, team: bool) -> str:
    """The JSON file an evaluation of ``learned`` with ``s`` writes, before it is played: the name
    (:func:`result_name`, :func:`team_result_name`) from the settings the evaluation records (the game of
    ``learned`` with the changes of ``s``; :func:`jaxdc.dcg.analysis.collector_eval.evaluate`,
    :func:`jaxdc.dcg.analysis.team.evaluate_learned`), so that a folder or a dangling symbolic link at it, or an
    input, is refused before any game."""
    if team:
        k = learned.collectors if s.collectors is None else s.collectors
        env, _ = learned.game(strategies=s.strategies)
        energy = learned.setting()["energy"] if s.energy is None else s.energy
        record = {"source": learned.source, "collectors": k, "greedy": bool(s.greedy), "run_seed": s.run_seed,
                  "seed": s.seed, "setting": {"energy": energy, "strategies": list(env.strategies)}}
        return os.path.join(s.out, team_result_name(record))
    env, params = learned.game(energy=s.energy, strategies=s.strategies, reward_area=s.reward_area,
                               max_steps=s.max_steps)
    mask = learned.mask if s.mask is None else s.mask
    record = {"net": learned.net_name, "alpha": learned.metadata.get("alpha"), "greedy": bool(s.greedy),
              "run_seed": s.run_seed, "seed": s.seed,
              "setting": {"energy": unlimited_to_json(float(params.max_energy)), "strategies": list(env.strategies),
                          "reward_area": s.reward_area}}
    if mask != "none":
        record["mask"] = mask
    return os.path.join(s.out, result_name(record))


def _figure(args, command) -> int:
    s = FigureSettings.from_args(args)
    _check_folders(args, "--out", "--img", "--cache", files=_figure_files(s.experiments),
                   inputs=_nets_dir_inputs(s.nets_dir))
    enable_compilation_cache()
    try:
        pool, folder = network_pool(s.nets_dir)
        if not pool:
            raise ValueError(f"no DCG parameter files in {folder}: train them with `python -m train.dcg --net NET "
                             "--ship` (or pass --nets-dir)")
        for name in s.experiments:
            exp = EXPERIMENTS[name]
            print(f"Figs. {'/'.join(exp.figures)} ({exp.caption}): {s.play.episodes} games per bar", file=sys.stderr)
            data = run_experiment(exp, pool, folder, s.play, s.cache, progress=lambda m: print(m, file=sys.stderr))
            gone = missing(pool, exp)
            if not any(data.results.values()):
                print(f"  no network for this experiment; missing: {'; '.join(gone)}", file=sys.stderr)
                continue
            verdicts = claims(exp, data.results, stored_standard(s.out) if name == "double_blind" else None)
            images = {}
            for fig_no, col in zip(exp.figures, ("reward", "rpe")):
                path = os.path.join(s.img, f"dcg_fig{fig_no.replace('.', '_')}.png")
                title = f"Fig. {fig_no} (ours): {'episode reward' if col == 'reward' else 'RPE'}\n{exp.caption}"
                images[path] = bar_chart_png(data.results, exp.groups, col, title, data.bounds,
                                             [f"{exp.group_name} {group_key(g)}" for g in exp.groups])
            if exp.per_strategy_chart:
                path = os.path.join(s.img, f"dcg_{name}_per_strategy.png")
                png = strategy_chart_png(data.results[None],
                                         f"Episode reward per opponent strategy (ours)\n{exp.caption}")
                if png is not None:
                    images[path] = png
            rel = [os.path.relpath(p, s.out) for p in images]
            payload = figure_payload(exp, data, verdicts, gone, command=command, episodes=s.play.episodes,
                                     seed=s.play.seed, greedy=s.play.greedy)
            md = figure_markdown(exp, data, verdicts, gone, command, rel)
            atomic_write_set({**images,  # the figure's files land together
                              os.path.join(s.out, f"figure_{name}.json"):
                                  json_text({**payload, "provenance": provenance()}) + "\n",
                              os.path.join(s.out, f"figure_{name}.csv"): figure_csv(data.results),
                              os.path.join(s.out, f"figure_{name}.md"): md})
            print(md)
    except (TypeError, ValueError) as e:
        args.error(str(e))
    return 0


def _render(args, command) -> int:
    _check_folders(args, "--out")
    try:
        s = RenderSettings.from_args(args)
        check_animation(".gif", s.fps)
    except (RuntimeError, ValueError) as e:
        args.error(str(e))
    enable_compilation_cache()
    try:
        learned = _load(s.checkpoint, s.net, s.run_seed)
        name = learned.net_name if learned.collectors == 1 else f"{source_stem(learned.source)}_k{learned.collectors}"
        for path in _render_paths(s, name):
            check_output_path(path, "--out file", _checkpoint_inputs(args))
        env, params = learned.game(energy=s.energy, strategies=(s.strategy,), reward_area=s.reward_area,
                                   max_steps=s.max_steps)
        policy = learned.policy(s.greedy)  # a team network: one copy per seat, each with the teammates plane
        policy = copies(policy, learned.collectors) if learned.collectors > 1 else policy
        states = play_episode(env, params, policy, jax.random.PRNGKey(s.seed), s.max_steps)
    except (TypeError, ValueError) as e:
        args.error(str(e))
    last = states[-1]
    strip, gif = _render_paths(s, name)
    files = {strip: strip_png(env, params, states, cols=s.cols),
             gif: animation_bytes(env, params, states, ".gif", fps=s.fps)}
    atomic_write_set(files)  # the strip and the animation land together
    print(f"{learned.net_name} vs {s.strategy}, seed {s.seed}: {len(states) - 1} steps, "
          f"reward {float(last.ep_reward):g}, outcome {OUTCOMES[int(last.outcome)]}")
    print(f"written {strip} and {gif}")
    return 0


def _render_paths(s: RenderSettings, net_name: str) -> tuple[str, str]:
    """The strip (PNG) and the animation (GIF) a render writes (``_run<S>`` for one seed of a ``--seeds`` run folder,
    as the results of ``evaluate``, so that the seeds of one folder do not overwrite each other)."""
    stem = (f"dcg_{net_name}_{s.strategy}" + ("" if s.run_seed is None else f"_run{s.run_seed}") + f"_s{s.seed}"
            + ("_greedy" if s.greedy else "") + (f"_area{s.reward_area}" if s.reward_area else ""))
    return os.path.join(s.out, stem + ".png"), os.path.join(s.out, stem + ".gif")


def _main(argv) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    explicit = bool(argv) and argv[0] in SUBCOMMANDS
    args = build_parser().parse_args(argv if explicit else [DEFAULT_SUBCOMMAND, *argv])
    command = f"{PROG} " + (f"{argv[0]} {shlex.join(argv[1:])}" if explicit else shlex.join(argv))
    try:
        return args.run(args, command)
    except jax.errors.JaxRuntimeError as e:  # the device ran out of memory: one line, what to lower
        if "RESOURCE_EXHAUSTED" not in str(e):
            raise
        raise MemoryError(f"{str(e).splitlines()[0]}; lower --episodes (or the game's size)") from None


def main(argv=None) -> int:
    """Run ``python -m eval.dcg`` on ``argv`` (default ``sys.argv[1:]``); a command line that does not start
    with a subcommand is an evaluation (``evaluate``). Returns the exit status (:func:`jaxdc.cli.runner.run`:
    a bad value exits 2 with one line, Ctrl-C 130); a bad flag exits 2 through argparse."""
    return run(_main, PROG, argv)
