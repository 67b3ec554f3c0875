"""Batched evaluation of DCP policies; reproduces the thesis' Tables 4.1 and 4.3-4.10 (navigators and learners).

Examples::

    python -m eval.dcp --policy safe_reward --risk high --total-reward 30 --energy 8 16 --episodes 10000 --seed 0
    python -m eval.dcp --policy enn --risk high --episodes 10000 --json   # the shipped ENN (Table 4.3 setting)
    python -m eval.dcp --policy eqn --checkpoint runs/dcp-eqn-high-s0     # a train.dcp run folder
    python -m eval.dcp --table 4.3                 # the whole table with the learned row, thesis beside ours
    python -m eval.dcp table 4.3                   # the same, as a subcommand
    python -m eval.dcp --table 4.7 --checkpoint my_enn.msgpack            # the learned row from an exported file
    python -m eval.dcp --table 4.1 --json          # one JSON object keyed by policy name
    python -m eval.dcp --policy safe_both --risk-map my_map.npy --energy 10 20

Subcommands: ``evaluate`` (the default, also when a command line names none)
plays one ``--policy``, or a table with ``--table T``; ``table T`` is
``evaluate --table T`` spelled as a subcommand.

A learned policy (``--policy enn|linear|cnn|eqn``) is the shipped parameter
file trained in the requested risk/energy setting (``jaxdc/assets/dcp``), or
``--checkpoint PATH`` (a ``train.dcp`` run folder or a ``.msgpack`` file).
Its environment settings come from the file's metadata unless given; it is
played in the environment it was trained in (no idle stop, as in
``train.dcp``). Actor-critics sample from their policy (section 4.5; ``--greedy``
for the argmax), EQN is epsilon-greedy with ``--epsilon`` 0.05 (section 4.5.5).

``--table`` fills the learned row of Tables 4.3-4.10 (ENN; the linear learner
in 4.9, EQN in 4.10) and the incr.% columns: the learner's increment over each
navigator as a percentage of the navigator's mean. Below the learned row, a
row ``<net> best`` plays the best shipped jaxdc learner of that table (beyond
the thesis: :mod:`jaxdc.dcp.analysis.best_learner`; named, with how its recipe differs,
under the table), and a table of one item (4.8) gets the row ``optimal``, the
exact optimum of value iteration; ``--no-best`` leaves both out. As in the thesis, the ENN of
Table 4.3 also plays Tables 4.6 and 4.8; Table 4.7 has its own ENN (energy 16/32).
Results of ``--table`` are written to ``--out`` (default ``results/dcp``) as
``table_<T>.json`` and ``table_<T>.md``, which land together (an interrupted
run leaves the previous pair or the new one); ``--out`` is checked before any
episode is played.

Every number is checked before any work: NaN is refused everywhere, ``inf``
only by ``--energy`` (no constraint) and ``--lpg-init`` (Algorithm 7's literal
reading); integers fit the int32 counters of the device code, seeds lie in
``0 .. 2**32 - 1``; a request too large for the machine's memory (``--grid-size``,
``--episodes``) is refused with what to lower. A statistic with no sample (RPE
when no episode consumed energy) is ``null`` in the JSON, with the reason in
``"undefined"``, and a dash in the table. A bad value exits with status 2 and
one ``error:`` line naming the flag; Ctrl-C exits 130.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys

from jaxdc import pretrained
from jaxdc.cli import eval_dcp_generalisation as generalisation
from jaxdc.cli import runner
from jaxdc.cli.args import check_run_seed, integer, positive_float, positive_int, real, seed, unit_interval
from jaxdc.cli.runner import command_line, with_subcommand
from jaxdc.core import grid
from jaxdc.core.energy import MAX_FINITE_ENERGY
from jaxdc.core.paths import PATH_RISK
from jaxdc.core.sampling import MAX_TOTAL_REWARD
from jaxdc.core.stats import format_number
from jaxdc.core.validate import value_text
from jaxdc.dcp import env as dcp_env
from jaxdc.dcp import learned as learned_lib
from jaxdc.dcp.analysis.best_learner import best_row
from jaxdc.dcp.analysis.best_learner import row_name as best_row_name
from jaxdc.dcp.analysis.risk_map import load_risk_map
from jaxdc.dcp.analysis.rows import Playing, evaluate_row, evaluate_rows, table_policies
from jaxdc.dcp.analysis.setting import DEFAULT_SETTING, EnvOptions, Setting, evaluation_setting
from jaxdc.dcp.analysis.table_learner import check_learner, shipped_learner
from jaxdc.dcp.analysis.table_results import best_markdown, markdown_table, table_markdown_file, table_payload
from jaxdc.dcp.analysis.tables import TABLES, TableSpec, incr_rows
from jaxdc.dcp.learned import EQN_EPSILON, NETS, Learned
from jaxdc.dcp.navigators import POLICIES
from jaxdc.dcp.planners import CF_DISTANCES, PlannerConfig
from jaxdc.io import atomic_write_set, check_output_folder, enable_compilation_cache, json_text
from jaxdc.provenance import provenance

PROG = "python -m eval.dcp"
#: Where ``--table`` writes its results unless ``--out`` is given.
DEFAULT_OUT = os.path.join("results", "dcp")
#: The subcommands; a command line that names none is an ``evaluate`` (as before they existed).
SUBCOMMANDS, DEFAULT_SUBCOMMAND = ("evaluate", "table", "generalisation"), "evaluate"
#: The tables, in the thesis' order.
TABLE_NAMES = sorted(TABLES, key=lambda t: float(t))


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``python -m eval.dcp``: the subcommands ``evaluate`` (one ``--policy``, or ``--table T``)
    and ``table T``; :func:`parse_args` puts ``evaluate`` in front of a command line without a subcommand."""
    description = __doc__.split("\n\n")[0]
    parser = argparse.ArgumentParser(prog=PROG, description=description)
    sub = parser.add_subparsers(dest="command", required=True, metavar="{" + ",".join(SUBCOMMANDS) + "}")
    p = sub.add_parser("evaluate", prog=PROG, description=description,
                       help="evaluate one policy, or a table with --table (the default)",
                       epilog="subcommand: `table T` (see `python -m eval.dcp table -h`)")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--policy", choices=POLICIES + ("optimal",) + NETS, default="safe_reward",
                      help="heuristic policy to evaluate; 'optimal' = exact value iteration (needs --total-reward 1); "
                           "enn/linear/cnn/eqn = a learned network (shipped, or --checkpoint)")
    what.add_argument("--table", choices=TABLE_NAMES, help="reproduce a thesis table")
    _add_options(p)
    t = sub.add_parser("table", prog=f"{PROG} table", description="Reproduce a thesis table (Tables 4.1, 4.3-4.10).",
                       help="reproduce a thesis table (the same as evaluate --table T)")
    t.add_argument("table", choices=TABLE_NAMES, help="the thesis table")
    t.set_defaults(policy=None)
    _add_options(t)
    g = generalisation.add_parser(sub, PROG)
    for q in (p, t, g):
        q.set_defaults(parser=q)
    return parser


def parse_args(argv=None) -> argparse.Namespace:
    """``argv`` (default ``sys.argv[1:]``) parsed, ``evaluate`` being the subcommand when none is named; the
    namespace's ``parser`` is the subcommand's (for its error messages)."""
    return build_parser().parse_args(with_subcommand(argv, SUBCOMMANDS, DEFAULT_SUBCOMMAND))


def _add_options(p: argparse.ArgumentParser) -> None:
    """The flags both subcommands take: the network, the setting, the thesis' ambiguities, the output."""
    p.add_argument("--checkpoint", metavar="PATH|NAME",
                   help="learned parameters: a train.dcp run folder, a .msgpack file or a shipped network's name "
                        "(e.g. enn_ppo; jaxdc.pretrained); "
                        "with --table, the table's learned row")
    p.add_argument("--run-seed", type=seed("--run-seed"), default=None, metavar="S",
                   help="--checkpoint of a train.dcp --seeds run: the seed whose network to evaluate")
    p.add_argument("--greedy", action="store_true",
                   help="learned policy: argmax instead of sampling (EQN: epsilon 0)")
    p.add_argument("--epsilon", type=unit_interval("--epsilon"), default=None,
                   help=f"EQN's evaluation epsilon (section 4.5.5: {EQN_EPSILON}); only where EQN is evaluated")
    p.add_argument("--no-learned", action="store_true", help="--table: navigator rows only")
    p.add_argument("--no-best", action="store_true",
                   help="--table: leave out the rows beyond the thesis (the best shipped jaxdc learner; the exact "
                        "optimum of a single-item table)")
    p.add_argument("--risk", choices=sorted(grid.RISK_PRESETS), default=None,
                   help="risk preset (Table 4.2; default high, or the learned network's)")
    p.add_argument("--risk-map", metavar="FILE", help="N x N risk map (.npy or JSON); overrides --risk")
    p.add_argument("--grid-size", type=integer("--grid-size", low=2), default=None,
                   help="N (default 8, the map's, or the learned network's)")
    p.add_argument("--total-reward", type=positive_int("--total-reward", high=MAX_TOTAL_REWARD), default=None,
                   help="default 30, or the learned network's (at most 2**24: the float32 item counts stay exact)")
    p.add_argument("--energy", nargs=2, type=positive_float("--energy", allow_inf=True, high=MAX_FINITE_ENERGY),
                   metavar=("INIT", "MAX"),
                   default=None,
                   help="initial and maximum energy; 'inf inf' for no constraint (default 8 16, or the learned "
                        "network's)")
    p.add_argument("--episodes", type=positive_int("--episodes"), default=10_000)
    p.add_argument("--seed", type=seed("--seed"), default=0)
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=None,
                   help="step cap (truncation; default 1000, or the learned network's)")
    # the thesis' ambiguities (docs/ambiguities.md)
    p.add_argument("--start", choices=dcp_env.STARTS, default="random_free")
    p.add_argument("--item-order", choices=dcp_env.ITEM_ORDERS, default="drop")
    p.add_argument("--energy-metric", choices=dcp_env.ENERGY_METRICS, default="not_stay_in_base")
    p.add_argument("--no-items-on-base", action="store_true", help="never drop items on the base cell")
    p.add_argument("--no-idle-stop", action="store_true",
                   help="do not end an episode whose step left the state unchanged (then only --max-steps ends it)")
    p.add_argument("--path-risk", choices=PATH_RISK, default="departed")
    p.add_argument("--cf-distance", choices=CF_DISTANCES, default="chebyshev")
    p.add_argument("--shortest-move", choices=grid.SHORTEST_MOVE_RULES, default="diagonal")
    p.add_argument("--lpg-init", type=real("--lpg-init", allow_inf=True), default=0.0,
                   help="LPG's initial loss sum (default 0; 'inf' is Algorithm 7 as printed)")
    p.add_argument("--rpe-zero", choices=("exclude", "zero"), default="exclude")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--out", default=None, help=f"folder for --table results (default {DEFAULT_OUT})")


@dataclasses.dataclass(frozen=True)
class EvalDCPSettings:
    """What one ``python -m eval.dcp`` run evaluates and where its results go, settled from the arguments."""

    table: TableSpec | None  # --table, else None (one --policy)
    policies: tuple[str, ...]  # the rows, in order
    learned: Learned | None  # the learned network of a learned row or --policy
    setting: Setting
    options: EnvOptions
    playing: Playing
    json: bool
    out: str
    command: str  # the command line, as the results files record it
    best: bool = False  # --table: add the row of the best shipped learner (jaxdc.dcp.analysis.best_learner)


def resolve_learned(args, spec: TableSpec | None = None) -> Learned | None:
    """The learned network to evaluate (``None`` if none): ``--checkpoint``, or the shipped one of the setting.

    For ``--table`` it is the table's learner (:mod:`jaxdc.dcp.analysis.table_learner`);
    a shipped file that is missing leaves the row out (``None``) and says so on
    stderr.
    """
    check_run_seed(args.run_seed, args.checkpoint, "train.dcp")
    if spec is None:
        if args.policy not in NETS:
            if args.checkpoint:
                raise ValueError(f"--checkpoint needs --policy one of {NETS} or --table, "
                                 f"got --policy {args.policy}")
            return None
        if args.checkpoint:
            return learned_lib.load(args.checkpoint, net=args.policy, grid_size=args.grid_size,
                                    run_seed=args.run_seed)
        return learned_lib.shipped(args.policy, args.risk or DEFAULT_SETTING["risk"],
                                   args.energy or DEFAULT_SETTING["energy"], grid_size=args.grid_size)
    if not spec.learned or args.no_learned:
        if args.checkpoint:
            raise ValueError(f"--checkpoint: Table {spec.name} has no learned row" if not spec.learned
                             else "--checkpoint and --no-learned exclude each other")
        return None
    if not args.checkpoint:
        try:
            return shipped_learner(spec, grid_size=args.grid_size)
        except ValueError as e:
            print(f"warning: Table {spec.name}: learned row {spec.learned[0]} left out: {e}", file=sys.stderr)
            return None
    learned = learned_lib.load(args.checkpoint, net=spec.learned[0], grid_size=args.grid_size,
                               run_seed=args.run_seed)
    try:
        return check_learner(spec, learned)
    except ValueError as e:
        raise ValueError(f"--checkpoint {args.checkpoint}: {e}") from None


def check_learned_flags(args, spec: TableSpec | None) -> None:
    """``ValueError`` for ``--greedy`` or ``--epsilon`` where no network they apply to is evaluated.

    ``--greedy`` needs a learned row or ``--policy enn|linear|cnn|eqn``; ``--epsilon`` needs EQN. A table
    whose shipped learner is missing (the row is left out with a warning) keeps them without effect.
    """
    if spec is not None and spec.learned and not args.no_learned:
        net = spec.learned[0]
    else:
        net = args.policy if spec is None and args.policy in NETS else None
    if args.greedy and net is None:
        raise ValueError("--greedy applies to a learned network; none is evaluated here "
                         f"({'--no-learned' if args.no_learned else 'Table ' + spec.name if spec else args.policy})")
    if args.epsilon is not None and net != "eqn":
        raise ValueError(f"--epsilon {value_text(args.epsilon)} is EQN's exploration; it does not apply to "
                         f"{net or 'the navigators'} (use --policy eqn or --table 4.10)")


def _table_rows(spec: TableSpec, learned: Learned | None, no_best: bool) -> tuple[str, ...]:
    """The rows of table ``spec``: its navigators and learned row, then (beyond the thesis, unless ``no_best``) the
    exact optimum when the table drops a single item (section 4.5.4's value iteration)."""
    rows = table_policies(spec, learned)
    return rows + ("optimal",) if spec.total_reward == 1 and not no_best else rows


def settle(args, spec: TableSpec | None, learned: Learned | None, argv=None) -> EvalDCPSettings:
    """The settings of the parsed arguments, given the table and the learned network already resolved.

    The learned network is resolved first (:func:`resolve_learned`), so that
    the run's first line names it before the setting is read (``--risk-map``);
    a ``ValueError`` names a bad value.
    """
    risk_map = load_risk_map(args.risk_map, "--risk-map") if args.risk_map else None
    setting = evaluation_setting(spec, learned, risk=args.risk, total_reward=args.total_reward, energy=args.energy,
                                 max_steps=args.max_steps, grid_size=args.grid_size, risk_map=risk_map)
    playing = Playing(episodes=args.episodes, seed=args.seed,
                      planner=PlannerConfig(cf_distance=args.cf_distance, shortest_move=args.shortest_move,
                                            lpg_init=args.lpg_init),
                      path_risk=args.path_risk, greedy=args.greedy,
                      epsilon=EQN_EPSILON if args.epsilon is None else args.epsilon, rpe_zero=args.rpe_zero)
    options = EnvOptions(start=args.start, items_on_base=not args.no_items_on_base, energy_metric=args.energy_metric,
                         idle_terminates=not args.no_idle_stop, item_order=args.item_order)
    return EvalDCPSettings(
        table=spec, policies=_table_rows(spec, learned, args.no_best) if spec else (args.policy,), learned=learned,
        setting=setting, options=options, playing=playing, json=args.json, out=args.out or DEFAULT_OUT,
        command=command_line(PROG, argv),
        best=bool(spec and learned is not None and not args.no_best))


def play_best(settings: EvalDCPSettings, rows: dict, progress=None):
    """Add the best shipped learner's row to ``rows`` (:func:`jaxdc.dcp.analysis.best_learner.best_row`: each
    candidate on the same episodes); ``(candidate, row name)`` or ``None`` when the table has none."""
    def evaluate(c):
        playing = dataclasses.replace(settings.playing, greedy=settings.playing.greedy or c.greedy)
        s = evaluate_row(c.learned.net_name, settings.setting, settings.options, playing, c.learned)
        if progress:
            progress(c.name, s)
        return s

    found = best_row(settings.table, evaluate, settings.setting.grid_size)
    if found is None:
        return None
    c, summary = found
    name = best_row_name(c.learned.net_name)
    rows[name] = summary
    return c, name


def write_table(settings: EvalDCPSettings, rows: dict, incr: dict, table: str, best=None) -> str:
    """Write ``table_<T>.json`` (strict JSON) and ``table_<T>.md`` into ``settings.out``, landing together;
    the JSON's path."""
    spec = settings.table
    path = os.path.join(settings.out, f"table_{spec.name}.json")
    record = {**table_payload(spec, settings.command, rows, incr, settings.learned, best), "provenance": provenance()}
    payload = json_text(record) + "\n"
    atomic_write_set({path: payload,
                      os.path.join(settings.out, f"table_{spec.name}.md"):
                          table_markdown_file(spec, settings.command, table)})
    return path


def main(argv=None) -> int:
    """Run the command line; the exit status (a bad flag value exits 2 through argparse, with one error line)."""
    args = parse_args(argv)
    parser = args.parser
    if args.command == "generalisation":
        try:
            return generalisation.main(args, PROG, argv)
        except (ValueError, TypeError, MemoryError) as e:
            parser.error(str(e))
    spec = TABLES[args.table] if args.table else None
    if spec and args.risk_map:
        parser.error("--table runs the thesis' own setting; it cannot take --risk-map")
    if spec:
        given = [f for f, v in (("--risk", args.risk), ("--total-reward", args.total_reward),
                                ("--energy", args.energy)) if v is not None]
        if given:
            parser.error(f"--table runs the thesis' own setting; it cannot take {', '.join(given)}")
    else:
        unused = [f for f, v in (("--out", args.out is not None), ("--no-learned", args.no_learned),
                                 ("--no-best", args.no_best)) if v]
        if unused:
            parser.error(f"{' and '.join(unused)} appl{'y' if len(unused) > 1 else 'ies'} only to --table; "
                         f"--policy {args.policy} evaluates one policy and writes no files")

    def progress(name, s):
        if not args.json:
            reward = format_number(s["reward"]["mean"], 2)
            print(f"  {name:14s} reward {reward}  ({s['seconds']:.1f} s)", file=sys.stderr)

    try:
        if args.energy is not None:
            try:
                dcp_env.check_energy(args.energy)
            except (TypeError, ValueError) as e:
                raise ValueError(f"--energy {value_text(args.energy[0])} {value_text(args.energy[1])}: {e}") from None
        if spec:
            check_output_folder(args.out or DEFAULT_OUT, "--out",
                                files=(f"table_{spec.name}.json", f"table_{spec.name}.md"),
                                inputs={"--checkpoint": args.checkpoint and pretrained.read_paths(args.checkpoint,
                                                                                                  "dcp")})
        check_learned_flags(args, spec)
        enable_compilation_cache()
        learned = resolve_learned(args, spec)
        if not args.json:
            what = f"Table {spec.name}: {spec.caption}" if spec else f"policy {args.policy}"
            print(f"Evaluating {what}, {args.episodes} episodes, seed {args.seed} ...", file=sys.stderr)
            if learned is not None:
                print(f"  learned: {learned.describe()}", file=sys.stderr)
        settings = settle(args, spec, learned, argv)
        with runner.progress(PROG, args.max_steps):  # a huge --max-steps: a line a minute while it plays
            rows = evaluate_rows(settings.policies, settings.setting, settings.options, settings.playing,
                                 settings.learned, progress)
            best = play_best(settings, rows, progress) if settings.best else None
    except (TypeError, ValueError, MemoryError) as e:
        parser.error(str(e))
    return show(settings, rows, best)


def show(settings: EvalDCPSettings, rows: dict, best=None) -> int:
    """Print the rows (one JSON object with ``--json``, else the markdown table); a table also writes its files.
    ``best``: the best shipped learner's ``(candidate, row name)``, named under the table."""
    spec = settings.table
    learner = settings.learned.net_name if settings.learned is not None else None
    incr = incr_rows(spec, rows, learner) if spec else {}
    shown = rows if best is None else {(f"{k}: {best[0].name}" if k == best[1] else k): v for k, v in rows.items()}
    table = markdown_table(spec, shown, incr, note=best_markdown(best) if best is not None else None)
    if spec:
        path = write_table(settings, rows, incr, table, best)
    if settings.json:
        print(json_text(rows if spec else rows[settings.policies[0]], indent=None))
    else:
        print(table)
        if spec:
            print(f"\nwritten to {path} and .md", file=sys.stderr)
    return 0
