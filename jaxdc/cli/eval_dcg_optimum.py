"""``python -m eval.dcg optimum``: the full-information bound of the DCG over sampled games (section 5.5;
:mod:`jaxdc.dcg.exact.many_items`, and :mod:`jaxdc.dcg.exact.team` for two collectors). Writes
``results/dcg/optimum_<settings>.json`` (:func:`jaxdc.dcg.analysis.report.optimum_name`).
"""

from __future__ import annotations

import argparse
import os
from typing import Any, Callable

import jax

from jaxdc.cli.args import integer, positive_int, seed
from jaxdc.cli.eval_dcg_settings import OptimumSettings
from jaxdc.dcg.analysis.report import optimum_name, optimum_payload, optimum_text
from jaxdc.dcg.env import CAPTURES, DCG, OPPONENT_STARTS, PATROL_TARGETS
from jaxdc.dcg.exact.machine import MAX_GRID_SIZE
from jaxdc.dcg.exact.many_items import sampled_bound
from jaxdc.dcg.exact.team import FOG_TARGETS
from jaxdc.dcg.exact.team import sampled_bound as team_bound
from jaxdc.dcg.opponents import CHASE_TIES, STANDARD_STRATEGIES
from jaxdc.io import atomic_write_json, check_output_folder, check_output_path, json_text, unlimited_to_json
from jaxdc.provenance import provenance

#: Most unit rewards ``optimum`` drops (each sampled game holds every unit while it is dropped).
MAX_UNITS = 1000


def add_parser(sub: Any, prog: str, results: str, energy_type: Callable[[], Callable],
               add_strategy_set: Callable[..., None]) -> None:
    """The ``optimum`` subcommand's parser on ``sub`` (``energy_type``: the ``--energy`` type of ``eval.dcg``;
    ``add_strategy_set``: its ``--strategies``/``--double-blind`` group)."""
    p = sub.add_parser("optimum", prog=f"{prog} optimum", help="estimate the full-information bound",
                       description="Estimate the full-information bound of the DCG over sampled games: the "
                                   "most reward any collector could take from each game, knowing the "
                                   "opponent's strategy and hidden state (jaxdc.dcg.exact.many_items).")
    p.add_argument("--grid-size", type=integer("--grid-size", low=2, high=MAX_GRID_SIZE), default=5,
                   help=f"N (5 in the thesis; 2..{MAX_GRID_SIZE} for the exact search)")
    p.add_argument("--total-reward", type=positive_int("--total-reward", high=MAX_UNITS), default=10,
                   help=f"unit rewards dropped (10; at most {MAX_UNITS})")
    p.add_argument("--energy", type=energy_type(), default=15.0,
                   help="maximum energy, a whole number or inf (15; 10/20 in Figs. 5.8-5.9)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=100, help="step cap (100)")
    p.add_argument("--chase-tie", choices=CHASE_TIES[:2], default=CHASE_TIES[0],
                   help="tie rule of 'moves towards' (deterministic ones only)")
    add_strategy_set(p, STANDARD_STRATEGIES, "the standard set of 5.5.1")
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
    p.add_argument("--collectors", type=integer("--collectors", low=1, high=2), default=1,
                   help="collectors in the team (1..2; 2: jaxdc.dcg.exact.team, exact where the search fits, "
                        "else its documented upper bound)")
    p.add_argument("--fog-target", choices=FOG_TARGETS, default=FOG_TARGETS[0],
                   help="with --collectors 2: the fog strategies' target reading (docs/dcg.md)")
    p.add_argument("--episodes", type=positive_int("--episodes"), default=2000, help="sampled games (2000)")
    p.add_argument("--seed", type=seed("--seed"), default=0, help="the games' PRNG key")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--out", default=results, help="folder for the result JSON")
    p.set_defaults(run=main, error=p.error)



def result_path(s: OptimumSettings, env: DCG) -> str:
    """The JSON file the search of ``s`` on ``env`` writes (:func:`optimum_name`; its name depends only on the
    settings, so it is known, and checked, before any game is searched)."""
    team = {} if s.collectors == 1 else {"collectors": s.collectors, "fog_target": s.fog_target}
    record = {"optimum": team, "env": repr(env), "energy": unlimited_to_json(s.energy), "max_steps": s.max_steps,
              "chase_tie": s.chase_tie, "seed": s.seed}
    return os.path.join(s.out, optimum_name(record, s.episodes))


def main(args: argparse.Namespace, command: str) -> int:
    """Run the subcommand; the exit status. The output folder and the result file in it (a folder or a dangling
    symbolic link at its name) are checked before any game is searched."""
    try:
        check_output_folder(args.out, "--out")
        s = OptimumSettings.from_args(args)
    except ValueError as e:
        args.error(str(e))
    try:
        env = DCG(**s.game)
        path = check_output_path(result_path(s, env), "--out file")
        params = env.make_params(energy=s.energy, max_steps=s.max_steps, chase_tie=s.chase_tie)
        if s.collectors == 1:
            res = sampled_bound(env, params, jax.random.PRNGKey(s.seed), s.episodes, progress=s.progress)
        else:
            res = team_bound(env, params, jax.random.PRNGKey(s.seed), s.episodes, fog_target=s.fog_target,
                             progress=s.progress)
    except (TypeError, ValueError, NotImplementedError) as e:
        args.error(str(e))
    out = optimum_payload(res, env, energy=s.energy, max_steps=s.max_steps, chase_tie=s.chase_tie, seed=s.seed,
                          command=command)
    written = os.path.join(s.out, optimum_name(out, s.episodes))
    if written != path:  # the name the search gives is the one checked; should they ever differ, check it too
        try:
            path = check_output_path(written, "--out file")
        except ValueError as e:
            args.error(str(e))
    line = json_text(out, indent=None)
    atomic_write_json(path, {**out, "provenance": provenance()})
    if s.json:
        print(line)
    else:
        print(optimum_text(out["optimum"], s.episodes))
        print(f"written {path}")
    return 0
