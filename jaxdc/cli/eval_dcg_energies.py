"""``python -m eval.dcg energies``: one DCG collector at several maximum energies, beside the full-information
bound at each and the shipped per-energy collectors of Figs. 5.8-5.9 (beyond the thesis: issue 28's "DCG over
energies"; :mod:`jaxdc.dcg.analysis.energies`). Writes ``results/dcg/energies_<name>_s<seed>.{json,md}``, where
``<name>`` is the network as given (:func:`network_label`), so two networks of one class do not share a file.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any, Callable

from jaxdc import pretrained
from jaxdc.cli.args import check_run_seed, integer, positive_int, seed
from jaxdc.core.energy import MAX_FINITE_ENERGY
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis.energies import energy_markdown, energy_table
from jaxdc.io import atomic_write_set, check_output_folder, enable_compilation_cache, json_text
from jaxdc.provenance import provenance

#: The maximum energies of the issue's goal (Figs. 5.8-5.9 train at 10, 15 and 20).
ENERGIES = [8, 10, 12, 15, 20, 25]


def add_parser(sub: Any, prog: str, add_network: Callable[[argparse.ArgumentParser], None], results: str,
               add_mask: Callable[[argparse.ArgumentParser], None]) -> None:
    """The ``energies`` subcommand's parser on ``sub`` (``add_network``: the ``--checkpoint``/``--net`` group;
    ``add_mask``: ``--mask``)."""
    p = sub.add_parser("energies", prog=f"{prog} energies", help="one collector at several maximum energies",
                       description="Play one collector at each maximum energy beside the full-information bound there "
                                   "and the shipped per-energy collectors of Figs. 5.8-5.9 (beyond the thesis).")
    add_network(p)
    p.add_argument("--energies", nargs="+", type=integer("--energies", low=1, high=int(MAX_FINITE_ENERGY)),
                   default=ENERGIES, help="whole maximum energies (8 10 12 15 20 25)")
    p.add_argument("--episodes", type=positive_int("--episodes"), default=2000, help="games per network and energy")
    p.add_argument("--bound-episodes", type=positive_int("--bound-episodes"), default=500,
                   help="games the bound is estimated over at each energy (500)")
    p.add_argument("--seed", type=seed("--seed"), default=0)
    p.add_argument("--greedy", action="store_true", help="argmax policy (default: sample from pi, as the thesis)")
    p.add_argument("--no-specialists", action="store_true", help="skip the shipped per-energy collectors")
    add_mask(p)
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--out", default=results, help="folder for the JSON and markdown")
    p.set_defaults(run=main, error=p.error)


def network_label(given: str) -> str:
    """The file-name part for the network the user gave: a shipped name or ``--net`` as it is, a parameter file's
    name without ``.msgpack``, a run folder's name (``runs/x/`` -> ``x``)."""
    base = os.path.basename(os.path.normpath(given))
    return base[: -len(".msgpack")] if base.endswith(".msgpack") else base


def main(args: argparse.Namespace, command: str) -> int:
    """Run the subcommand; the exit status. The output folder, and that no output overwrites the network's files,
    are checked before the games are played."""
    try:
        check_output_folder(args.out, "--out")
        check_run_seed(args.run_seed, args.checkpoint, "train.dcg")
        learned = (learned_lib.load(args.checkpoint, run_seed=args.run_seed) if args.checkpoint
                   else learned_lib.shipped(args.net))
        given = args.checkpoint or args.net
        mask = learned.mask if args.mask is None else args.mask
        play = ("_greedy" if args.greedy else "") + ("" if mask == "none" else f"_mask-{mask}")
        run = "" if args.run_seed is None else f"_run{args.run_seed}"
        stem = os.path.join(args.out, f"energies_{network_label(given)}{play}{run}_s{args.seed}")
        check_output_folder(args.out, "--out", files=[os.path.basename(stem) + ext for ext in (".json", ".md")],
                            inputs={"--checkpoint": pretrained.read_paths(args.checkpoint, "dcg")
                                    if args.checkpoint else None})
    except (TypeError, ValueError) as e:
        args.error(str(e))
    enable_compilation_cache()
    try:
        say = None if args.json else (lambda m: print(m, file=sys.stderr))
        table = energy_table(learned, args.energies, episodes=args.episodes, seed=args.seed,
                             bound_episodes=args.bound_episodes, greedy=args.greedy,
                             specialists=not args.no_specialists, progress=say, mask=args.mask)
    except (TypeError, ValueError) as e:
        args.error(str(e))
    table["source"] = given  # as the user gave it (a shipped name, or the path on the command line)
    table["command"] = command
    md = energy_markdown(table)
    atomic_write_set({stem + ".json": json_text({**table, "provenance": provenance()}) + "\n", stem + ".md": md})
    if args.json:
        print(json_text(table, indent=None))
    else:
        print(md)
        print(f"written {stem}.json and {stem}.md", file=sys.stderr)
    return 0
