"""Stored section 3.5 experiments: a figure's results are computed once and reused for the same settings.

An experiment's record (:func:`jaxdc.drp.analysis.summary.experiment_record`) is stored as
``experiment_<tag>.json`` (:attr:`jaxdc.drp.analysis.experiment.ExperimentConfig.tag`) with the settings it
was made with; :func:`stored_experiment` gives it back only when they match, and a file that cannot be read
or lacks its rows is recomputed, with one line saying so.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable

from jaxdc.drp.analysis.experiment import ExperimentConfig
from jaxdc.io import read_json


def _stderr(message: str) -> None:
    print(message, file=sys.stderr)


def experiment_path(out: str, config: ExperimentConfig) -> str:
    """Where the experiment of ``config`` is stored in the folder ``out``."""
    return os.path.join(out, f"experiment_{config.tag}.json")


def stored_experiment(path: str, config: ExperimentConfig, warn: Callable[[str], None] = _stderr) -> dict | None:
    """The stored record at ``path`` if it exists and was made with ``config``, else ``None``.

    A stored file that cannot be read, is not strict JSON or lacks the summary rows gives ``None`` too, and
    ``warn`` (default: a line on stderr) is told why.
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
    if not isinstance(stored.get("rows"), list) or not isinstance(stored.get("wall_seconds"), (int, float)):
        warn(f"stored results {path} lack their rows; recomputing")
        return None
    return stored


def compute_experiment(config: ExperimentConfig, *, workers: int = 1, xla_cache: bool = False,
                       quiet: bool = False) -> dict:
    """Run the experiment of ``config`` (over ``workers`` processes when more than one) and give its record."""
    from jaxdc.drp.analysis.experiment import run_experiment
    from jaxdc.drp.analysis.parallel import run_parallel
    from jaxdc.drp.analysis.summary import experiment_record
    from jaxdc.drp.solve import CLUSTERINGS
    from jaxdc.drp.tours import BUILDERS

    c = config
    alphas = list(c.alphas)
    t0 = time.perf_counter()
    if workers > 1:
        raw, timing = run_parallel(workers, c.rewards, c.graphs, c.nodes, alphas, c.base, c.seed, xla_cache, quiet)
    else:
        raw, timing = run_experiment(c.rewards, c.graphs, c.nodes, alphas, c.base, c.seed, BUILDERS, CLUSTERINGS,
                                     quiet=quiet)
    return experiment_record(c.as_dict(), raw, timing, time.perf_counter() - t0, alphas)
