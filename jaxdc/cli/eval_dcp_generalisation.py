"""``python -m eval.dcp generalisation``: a learned DCP network over a grid of maps and budgets.

Examples::

    python -m eval.dcp generalisation --checkpoint enn_general
    python -m eval.dcp generalisation --checkpoint runs/gen --maps-per-source 4 --episodes 10000 --seed 5
    python -m eval.dcp generalisation --checkpoint runs/pooled --grid-size 10 --no-thesis

The grid (:mod:`jaxdc.dcp.analysis.generalisation`): maps of the network's
training set, held-out generated maps (seeds no training run may use) and the
thesis' three maps, each with every budget of ``--budgets``. Each setting
plays the network, the four navigators (the best is the yardstick), the
network with one item against the exact optimum (``--no-optimum`` skips it),
the shipped specialist of that setting where there is one and, with ``--bound``,
the unlimited-energy bound of every policy (:mod:`jaxdc.dcp.exact.unlimited`),
all on the same episode keys. Writes ``generalisation.json``, ``generalisation.md``,
``generalisation_ratio.png`` (network / best navigator, map x budget; budgets
inside the training range are starred) and, with the optimum,
``generalisation_one_item.png`` into ``--out`` (default
``results/dcp/generalisation``), all landing together. ``--grid-size`` plays the grid on another
``N x N`` grid than the network's, for a network whose body pools over the cells (``train.dcp --body-pool
mean_max``); the thesis tables are always played on the thesis' 8x8 grid, so a network that plays only another
size needs ``--no-thesis`` (refused before any work otherwise).
"""

from __future__ import annotations

import argparse
import os
import sys

from jaxdc import pretrained
from jaxdc.cli.args import integer, positive_int, seed
from jaxdc.cli.runner import command_line
from jaxdc.core.generators import GENERATORS, MAX_SEED_COUNT
from jaxdc.core.grid import check_grid_size
from jaxdc.core.validate import value_text
from jaxdc.dcp import learned as learned_lib
from jaxdc.dcp.analysis import generalisation as gen
from jaxdc.dcp.env import MAX_RANGE
from jaxdc.dcp.exact.unlimited import MAX_ITEM_CELLS
from jaxdc.io import atomic_write_set, check_output_folder, enable_compilation_cache, json_text
from jaxdc.provenance import provenance

#: Where the grid's files land unless ``--out`` is given.
DEFAULT_OUT = os.path.join("results", "dcp", "generalisation")
#: The files the grid writes into ``--out``.
OUTPUT_FILES = ("generalisation.json", "generalisation.md", "generalisation_ratio.png", "generalisation_one_item.png")


def add_parser(sub, prog: str) -> argparse.ArgumentParser:
    """The ``generalisation`` subcommand's parser."""
    p = sub.add_parser("generalisation", prog=f"{prog} generalisation",
                       description="A learned network over maps and budgets it was and was not trained on.")
    p.add_argument("--checkpoint", required=True,
                   help="a shipped name (enn_general), a .msgpack file or a train.dcp run folder")
    p.add_argument("--maps-per-source", type=positive_int("--maps-per-source", high=MAX_SEED_COUNT), default=2,
                   help="training maps and held-out maps in the grid (each; the thesis' three maps always)")
    p.add_argument("--budgets", type=float, nargs="+", default=None, metavar="E",
                   help="pairs INIT MAX, e.g. 8 16 16 32 (default: 4/8 6/12 8/16 12/24 16/32 24/48 32/64)")
    p.add_argument("--generator", choices=tuple(GENERATORS), default=None,
                   help="the generator of the held-out maps (default: the network's own training generator)")
    p.add_argument("--grid-size", type=integer("--grid-size", low=2), default=None, metavar="N",
                   help="play the maps on N x N grids (default: the network's own grid size; another size needs a "
                        "network that plays every grid size, train.dcp --body-pool mean_max)")
    p.add_argument("--total-reward", type=positive_int("--total-reward"), default=30)
    p.add_argument("--episodes", type=positive_int("--episodes"), default=2000)
    p.add_argument("--seed", type=seed("--seed"), default=5)
    p.add_argument("--greedy", action="store_true", help="play the network's argmax instead of sampling")
    p.add_argument("--no-optimum", action="store_true", help="skip the one-item rows against the exact optimum")
    p.add_argument("--no-specialist", action="store_true", help="skip the shipped specialists")
    p.add_argument("--bound", action="store_true",
                   help="also the unlimited-energy bound of every policy on the same episodes, and its ratio to the "
                        f"best navigator (the most any policy could gain there); needs --total-reward <= "
                        f"{MAX_ITEM_CELLS}")
    p.add_argument("--no-thesis", action="store_true",
                   help="skip the network in each thesis table's setting against that table's ENN")
    p.add_argument("--thesis-episodes", type=positive_int("--thesis-episodes"), default=10_000,
                   help="episodes of each thesis-table setting (default 10,000, as the thesis)")
    p.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})")
    p.add_argument("--json", action="store_true", help="print the JSON instead of the markdown")
    return p


def budgets(values: list[float] | None) -> tuple[tuple[float, float], ...]:
    """``--budgets`` as pairs; a ``ValueError`` names the flag."""
    if values is None:
        return gen.BUDGETS
    if len(values) % 2:
        raise ValueError(f"--budgets takes pairs INIT MAX, got {len(values)} numbers")
    pairs = tuple((float(values[i]), float(values[i + 1])) for i in range(0, len(values), 2))
    for e0, e1 in pairs:
        if not (1 <= e0 <= e1 < 2**24) or e0 != int(e0) or e1 != int(e1):
            raise ValueError("--budgets: each pair must be whole numbers 1 <= INIT <= MAX, got "
                             f"{value_text(e0)} {value_text(e1)}")
    return pairs


def specialist_finder(total_reward: int):
    """``setting -> Learned | None``: the shipped ENN of a thesis map and budget, if one is shipped (on the
    setting's grid size)."""
    def find(setting: gen.Setting):
        if setting.source != "thesis" or total_reward != 30:
            return None
        name = learned_lib.shipped_name("enn", setting.map_name, setting.energy)
        try:
            return learned_lib.load(pretrained.shipped("dcp", name), net="enn", grid_size=setting.risk.shape[0])
        except ValueError:
            return None
    return find


def grid_size_of(learned: learned_lib.Learned, wanted: int | None) -> int:
    """The grid size to play: ``wanted`` (``--grid-size``) or the network's own; another size than the network's
    only for a network that plays every grid size (:func:`jaxdc.dcp.learned.plays_any_grid`), else a
    ``ValueError`` naming ``--grid-size``."""
    own = learned.setting()["grid_size"]
    if wanted is None or wanted == own:
        return own
    try:
        check_grid_size(wanted, max_cells=MAX_RANGE)  # the DCP's own bound, before any map is drawn
    except ValueError as e:
        raise ValueError(f"--grid-size: {e}") from None
    if not learned_lib.plays_any_grid(learned.metadata):
        raise ValueError(f"--grid-size {wanted}: {learned.source} was trained on a {own}x{own} grid and its body "
                         f"flattens the grid, so it plays only that size (a network trained with --body-pool "
                         f"mean_max plays every size)")
    return wanted


def main(args: argparse.Namespace, prog: str, argv=None) -> int:
    """Run the grid of the parsed ``args``; exit status 0."""
    pairs = budgets(args.budgets)
    if args.bound and args.total_reward > MAX_ITEM_CELLS:
        raise ValueError(f"--bound needs --total-reward <= {MAX_ITEM_CELLS} (the exact tour search holds 2**cells "
                         f"values per episode), got {args.total_reward}")
    out = check_output_folder(args.out, "--out", files=OUTPUT_FILES,
                              inputs={"--checkpoint": pretrained.read_paths(args.checkpoint, "dcp")})
    learned = learned_lib.load(args.checkpoint, net="enn")
    grid_size = grid_size_of(learned, args.grid_size)
    own = learned.setting()["grid_size"]
    if not args.no_thesis and own != gen.THESIS_GRID and not learned_lib.plays_any_grid(learned.metadata):
        raise ValueError(f"--no-thesis is needed: the thesis tables are played on the thesis' {gen.THESIS_GRID}x"
                         f"{gen.THESIS_GRID} grid, and {learned.source} plays only {own}x{own}")
    grid = gen.settings(learned.metadata, args.maps_per_source, pairs, grid_size, args.generator)
    enable_compilation_cache()
    command = command_line(prog, argv)

    def progress(i, n, row):
        print(f"[{i}/{n}] {row['source']} {row['map']} {row['energy'][0]:g}/{row['energy'][1]:g}: "
              f"net {row['net']['mean']:.2f}, {row['best_navigator']['name']} {row['best_navigator']['mean']:.2f}"
              + (f", bound {row['bound']['mean']:.2f}" if "bound" in row else ""), file=sys.stderr, flush=True)

    rows = gen.run(learned, grid, args.total_reward, args.episodes, args.seed, not args.no_optimum,
                   None if args.no_specialist else specialist_finder(args.total_reward), args.greedy, progress,
                   args.bound)
    thesis = [] if args.no_thesis else gen.thesis_tables(learned, args.thesis_episodes, args.seed, args.greedy)
    payload = {"network": learned.source, "command": command, "grid_size": grid_size,
               "training_range": list(gen.training_range(learned.metadata)), "rows": rows,
               "summary": gen.summarise(rows), "thesis_tables": thesis, "provenance": provenance(argv)}
    text = gen.markdown(rows, command, learned.source) + ("\n" + gen.thesis_markdown(thesis) if thesis else "")
    files = {os.path.join(out, "generalisation.json"): json_text(payload),
             os.path.join(out, "generalisation.md"): text}
    files.update(pictures(rows, learned.metadata, out))
    atomic_write_set(files)
    print(json_text(payload) if args.json else text)
    return 0


def pictures(rows: list[dict], metadata: dict, out: str) -> dict:
    """The heat maps as ``{path: PNG bytes}``."""
    from jaxdc.viewer.heatmap import heatmap_png

    low, high = gen.training_range(metadata)
    files = {}
    for key, name, title in (("ratio", "generalisation_ratio.png", "network / best navigator"),
                             ("share", "generalisation_one_item.png", "one item: network / exact optimum")):
        values, maps, cols = gen.heat_values(rows, key)
        if all(v is None for row in values for v in row):
            continue
        inside = [low <= float(c.split("/")[1]) <= high for c in cols]
        files[os.path.join(out, name)] = heatmap_png(values, maps, cols, f"{title} (* budget inside training)",
                                                     marked_cols=inside)
    return files
