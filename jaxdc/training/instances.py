"""The training distribution of a DCP run with per-episode instances (beyond the thesis; docs/generalisation.md).

A run that sets ``risk_maps`` or ``energy_range`` (:class:`jaxdc.training.dcp.DCPSettings`) trains on
episodes that each draw a risk map from a seeded set of generated maps and a maximum energy from a range
(:mod:`jaxdc.dcp.instances`; ``energy_tilt``: by a power law that weights one end of it). The held-out maps of
the generalisation benchmark are the seeds of :data:`HELD_OUT`; a training run that names one of them is refused,
so no test map is ever trained on.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from jaxdc.core import generators
from jaxdc.core.validate import check_float, check_int
from jaxdc.dcp import instances
from jaxdc.dcp.env import DCP, OBSERVATIONS, EnvParams
from jaxdc.training.fields import check_tilt_has_range

#: The held-out map seeds: the test maps of ``eval.dcp generalisation`` are drawn from these, training never.
HELD_OUT = generators.SeedSet(generators.TEST_SEED_START, 1 << 20)


def check_instance_settings(s: Any) -> None:
    """Validate the instance fields of DCP settings ``s`` (names the field, the value and the range)."""
    if s.observation not in OBSERVATIONS:
        raise ValueError(f"observation must be one of {OBSERVATIONS}, got {s.observation!r}")
    if s.risk_maps is not None:
        generators.generator(s.risk_maps)
    try:
        start, count = s.map_seeds
    except (TypeError, ValueError):
        raise TypeError(f"map_seeds must be a pair (start, count), got {s.map_seeds!r}") from None
    seeds = generators.SeedSet(check_int("map_seeds start", start, 0), check_int("map_seeds count", count, 1))
    if s.risk_maps is not None:
        generators.check_disjoint(seeds, HELD_OUT)
    if s.energy_range is not None:
        instances.check_energy_range(s.energy_range)
    check_tilt_has_range(s.energy_tilt, s.energy_range)
    check_float("init_fraction", s.init_fraction, 0.0, 1.0, low_open=True)


def instance_metadata(s: Any) -> dict:
    """The instance fields of ``s`` for a run's metadata; empty in the thesis' setting (old files unchanged)."""
    out: dict = {}
    if s.observation != "thesis":
        out["observation"] = s.observation
    if s.risk_maps is not None:
        out["risk_maps"] = s.risk_maps
        out["map_seeds"] = list(s.map_seeds)
    if s.energy_range is not None:
        out["energy_range"] = list(s.energy_range)
    if s.energy_tilt != 0.0:
        out["energy_tilt"] = s.energy_tilt
    if s.risk_maps is not None or s.energy_range is not None:
        out["init_fraction"] = s.init_fraction
    return out


def training_params(s: Any, env: DCP) -> EnvParams:
    """The per-episode params of ``s``: its map set (or the ``risk`` preset alone) and budget range."""
    if s.risk_maps is not None:
        maps = generators.make_maps(generators.generator(s.risk_maps), generators.SeedSet(*s.map_seeds),
                                    env.grid_size)
    else:
        maps = np.asarray(env.make_params(s.risk, tuple(s.energy), s.max_steps).risk)[None]
    energy_range = s.energy_range if s.energy_range is not None else (s.energy[1], s.energy[1])
    fraction = s.init_fraction if s.energy_range is not None else s.energy[0] / s.energy[1]
    return instances.instance_params(env, maps, energy_range, fraction, s.max_steps, s.energy_tilt)
