"""Stored section 3.5 experiments: a figure's results are computed once and reused for the same settings.

An experiment's record (:func:`jaxdc.drp.analysis.summary.experiment_record`) is stored as
``experiment_<tag>.json`` (:attr:`jaxdc.drp.analysis.experiment.ExperimentConfig.tag`) with the settings it
was made with; :func:`stored_experiment` gives it back only when they match, and a file that cannot be read
or is damaged (:func:`check_experiment`: a missing or malformed field of its config or rows) is recomputed, with
one line naming the file and the field.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable

from jaxdc.core.record_fields import Fields, key_path
from jaxdc.drp.analysis.experiment import ExperimentConfig
from jaxdc.drp.solve import CLUSTERINGS
from jaxdc.drp.tours import BUILDERS
from jaxdc.io import read_json


def _stderr(message: str) -> None:
    print(message, file=sys.stderr)


def experiment_path(out: str, config: ExperimentConfig) -> str:
    """Where the experiment of ``config`` is stored in the folder ``out``."""
    return os.path.join(out, f"experiment_{config.tag}.json")


def check_experiment(record, path: str, hint: str = "") -> dict:
    """``record`` (the stored experiment read from ``path``) if its config and summary rows are sound, else a
    ``ValueError`` naming ``path`` and the key (``rows[3].builder is missing``), followed by ``hint``.

    Checked: the config's sizes and robot values; ``wall_seconds``; every row's clustering and builder (known
    names), ``alpha`` (one of the config's), ``mean`` and ``sd`` (numbers, or ``null`` with the reason in
    ``undefined``) and ``pgc_over_nc`` (a number or ``null`` when present); and that the rows hold one row per
    clustering, builder and robot value, no more and no fewer (the figure and the tables read every one).
    """
    f = Fields(path, hint)
    f.obj(record)
    cfg = f.get_obj(record, "config")
    f.get_text(cfg, "rewards", "config")
    f.get_number(cfg, "graphs", "config", integer=True, minimum=1)
    f.get_number(cfg, "nodes", "config", integer=True, minimum=1)
    alphas = [f.number(a, f"config.alphas[{i}]") for i, a in enumerate(f.get_items(cfg, "alphas", "config"))]
    if 0 not in alphas:
        raise f.error("config.alphas", f"must include 0 (the normaliser's robot value), got {alphas!r}")
    f.get_number(record, "wall_seconds", minimum=0)
    seen = {}
    for i, row in enumerate(f.get_items(record, "rows")):
        at = f"rows[{i}]"
        f.obj(row, at)
        c = f.get_text(row, "clustering", at, choices=CLUSTERINGS)
        b = f.get_text(row, "builder", at, choices=BUILDERS)
        a = f.get_number(row, "alpha", at)
        if a not in alphas:
            raise f.error(key_path(at, "alpha"), f"{a!r} is not one of config.alphas")
        mean = f.get_number(row, "mean", at, optional=True)
        sd = f.get_number(row, "sd", at, optional=True, minimum=0)
        if (mean is None) != (sd is None):
            raise f.error(at, "must have both mean and sd, or neither (null)")
        if mean is None:
            f.get_text(row, "undefined", at)
        f.get_number(row, "pgc_over_nc", at, optional=True, absent=True)
        if (c, b, a) in seen:
            raise f.error(at, f"repeats {seen[c, b, a]} (clustering {c!r}, builder {b!r}, alpha {a:g})")
        seen[c, b, a] = at
    for c in CLUSTERINGS:
        for b in BUILDERS:
            for a in alphas:
                if (c, b, a) not in seen:
                    raise f.error("rows", f"have no row for clustering {c!r}, builder {b!r}, alpha {a:g}")
    return record


def check_gaps(record, path: str, hint: str = "") -> dict:
    """``record`` (``python -m eval.drp gaps``'s file at ``path``) if its config and rows are sound, else a
    ``ValueError`` naming ``path`` and the key: the config's sizes, and per row the clustering, builder and
    ``mean_ratio`` (a number, or ``null`` with the reason in ``undefined``; a number comes with ``graphs``,
    ``min_ratio`` and ``optimal_share``)."""
    f = Fields(path, hint)
    f.obj(record)
    cfg = f.get_obj(record, "config")
    f.get_number(cfg, "graphs", "config", integer=True, minimum=1)
    f.get_number(cfg, "nodes", "config", integer=True, minimum=1)
    f.get_text(cfg, "base", "config")
    for i, row in enumerate(f.get_items(record, "rows")):
        at = f"rows[{i}]"
        f.obj(row, at)
        f.get_text(row, "clustering", at, choices=CLUSTERINGS)
        f.get_text(row, "builder", at, choices=BUILDERS)
        if f.get_number(row, "mean_ratio", at, optional=True) is None:
            f.get_text(row, "undefined", at)
            continue
        f.get_number(row, "graphs", at, integer=True, minimum=1)
        f.get_number(row, "min_ratio", at)
        f.get_number(row, "optimal_share", at, minimum=0)
    return record


def stored_experiment(path: str, config: ExperimentConfig, warn: Callable[[str], None] = _stderr) -> dict | None:
    """The stored record at ``path`` if it exists and was made with ``config``, else ``None``.

    A stored file that cannot be read, is not strict JSON or is damaged (:func:`check_experiment`) gives ``None``
    too, and ``warn`` (default: a line on stderr) is told why, naming the file and the damaged field.
    """
    if not os.path.exists(path):
        return None
    try:
        stored = read_json(path)
    except ValueError as e:
        warn(f"stored results cannot be read ({e}); recomputing")
        return None
    if not isinstance(stored, dict) or stored.get("config") != config.as_dict():
        return None
    try:
        return check_experiment(stored, path)
    except ValueError as e:
        warn(f"stored results are damaged ({e}); recomputing")
        return None


def compute_experiment(config: ExperimentConfig, *, workers: int = 1, xla_cache: bool = False,
                       quiet: bool = False) -> dict:
    """Run the experiment of ``config`` (over ``workers`` processes when more than one) and give its record."""
    from jaxdc.drp.analysis.experiment import run_experiment
    from jaxdc.drp.analysis.parallel import run_parallel
    from jaxdc.drp.analysis.summary import experiment_record

    c = config
    alphas = list(c.alphas)
    t0 = time.perf_counter()
    if workers > 1:
        raw, timing = run_parallel(workers, c.rewards, c.graphs, c.nodes, alphas, c.base, c.seed, xla_cache, quiet)
    else:
        raw, timing = run_experiment(c.rewards, c.graphs, c.nodes, alphas, c.base, c.seed, BUILDERS, CLUSTERINGS,
                                     quiet=quiet)
    return experiment_record(c.as_dict(), raw, timing, time.perf_counter() - t0, alphas)
