"""The metadata of training runs and parameter files: its schema, its format and the one upgrade of older files.

This module sits below the problems and training (:mod:`jaxdc.pretrained`,
:mod:`jaxdc.checkpoint`'s readers and :mod:`jaxdc.training` all read it), so
the problems do not depend on training.

A run's metadata (its ``config.json`` and the metadata of each checkpoint,
:mod:`jaxdc.training.dcp`, :mod:`jaxdc.training.dcg`) and a parameter file's
JSON sidecar (:func:`jaxdc.pretrained.save`) carry ``"format"``:

* format 1 (files without ``"format"`` are format 1): optional settings were
  left out when unset (``min_total_reward``; ``reward_area``,
  ``min_reward_area``), the learner options beside Algorithm 10 were left out
  of an A2C run's ``algorithm`` at their defaults, and an n-step Q run's
  ``algorithm`` held A2C's loss weights, which it does not use;
* format 2 (:data:`FORMAT`): every optional setting is written (``null`` when
  unset) and ``algorithm`` holds exactly the fields of the config that trained
  (``A2CConfig`` or ``QConfig``).

:func:`upgrade` turns any older metadata into the current format; it is the
only place that knows the old ones. Readers call it on load, so a file of any
format reads the same.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

from jaxdc.core.validate import is_int
from jaxdc.nets.registry import DCP_NETS, NSTEP_Q, REGISTRIES

#: The format written now.
FORMAT = 2
#: Optional settings of each problem, written as ``None`` when unset (format 2).
OPTIONAL_SETTINGS = {"dcp": ("min_total_reward",), "dcg": ("reward_area", "min_reward_area")}
#: The keys of a run's metadata (``config.json``, :func:`jaxdc.training.dcp.run_metadata`,
#: :func:`jaxdc.training.dcg.run_metadata`) for each problem, in the order they are written.
RUN_KEYS = {
    "dcp": ("format", "net", "problem", "grid_size", "total_reward", "risk", "energy", "max_steps",
            "min_total_reward", "seed", "seeds", "algorithm", "observation", "risk_maps", "map_seeds", "energy_range",
            "energy_tilt", "item_tilt", "init_fraction", "body_features", "body_hidden", "body_pool", "heuristic_rows",
            "grid_sizes", "init_from",
            "init_sha256"),
    "dcg": ("format", "net", "problem", "grid_size", "total_reward", "strategies", "energy", "max_steps", "history",
            "alpha", "reward_area", "min_reward_area", "seed", "seeds", "algorithm", "observation", "energy_range",
            "energy_tilt", "collectors", "algo", "mask", "init_from", "init_sha256"),
}
#: Entries of :data:`RUN_KEYS` that record a fact of the run, not a setting (no flag sets them): the SHA-256 of the
#: parameters a warm start began from (``train.dcp --init-from``, ``train.dcg --init-from``).
RECORDS = ("init_sha256",)
#: Metadata entries that are counts (ints >= 1), checked on read.
COUNTS = ("grid_size", "total_reward", "max_steps", "steps", "updates", "min_total_reward", "reward_area",
          "min_reward_area")
#: Metadata entries that are ints >= 0.
NONNEGATIVE = ("seed", "history")


def _config_class(net: str | None) -> type:
    """``QConfig`` for a network trained by n-step Q-learning (the registry's ``"nstep_q"``), else ``A2CConfig``."""
    from jaxdc.agents.a2c import A2CConfig
    from jaxdc.agents.nstep_q import QConfig

    nets = {name: e for registry in REGISTRIES.values() for name, e in registry.items()}
    return QConfig if net in nets and nets[net].algorithm == NSTEP_Q else A2CConfig


def algorithm_fields(net: str | None) -> dict:
    """``{field: default}`` of the config that trains ``net`` (``QConfig`` for EQN, else ``A2CConfig``)."""
    cls = _config_class(net)
    return {f.name: f.default for f in dataclasses.fields(cls)}


def check_values(meta: dict, where: str) -> dict:
    """``meta`` if its settings have sensible types and ranges (:data:`COUNTS`, :data:`NONNEGATIVE`, the energy a
    number > 0 or ``"inf"``, EMNN's ``alpha`` a number >= 0 or null); else a ``ValueError`` naming ``where`` and the
    key."""
    for key in COUNTS:
        v = meta.get(key)
        if v is not None and (not is_int(v, numpy=False) or v < 1):
            raise ValueError(f"{where}: metadata {key}={v!r} must be an int >= 1")
    for key in NONNEGATIVE:
        v = meta.get(key)
        if v is not None and (not is_int(v, numpy=False) or v < 0):
            raise ValueError(f"{where}: metadata {key}={v!r} must be an int >= 0")
    if "energy" in meta:
        values = meta["energy"] if isinstance(meta["energy"], list) else [meta["energy"]]
        for v in values:
            number = isinstance(v, (int, float)) and not isinstance(v, bool)
            if number and math.isinf(v):  # a JSON number too large for a float (1e400) reads as infinity
                raise ValueError(f"{where}: metadata energy={meta['energy']!r} holds a number too large for a float "
                                 "(e.g. 1e400); write the string \"inf\" for no energy limit")
            if not (v == "inf" or (number and math.isfinite(v) and v > 0)):
                raise ValueError(f"{where}: metadata energy={meta['energy']!r} must hold numbers > 0 (or \"inf\")")
    alpha = meta.get("alpha")
    if alpha is not None and (isinstance(alpha, bool) or not isinstance(alpha, (int, float))
                              or not math.isfinite(alpha) or alpha < 0):
        raise ValueError(f"{where}: metadata alpha={alpha!r} must be null or a finite number >= 0 (a JSON number, "
                         "not a string)")
    return meta


def upgrade(meta: dict) -> dict:
    """``meta`` (of any format) in the current format :data:`FORMAT`; a ``ValueError`` for a newer one."""
    meta = dict(meta)
    version = meta.get("format", 1)
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= FORMAT:
        raise ValueError(f"metadata format {version!r} is not one this jaxdc reads (1..{FORMAT}); "
                         "was the file written by a newer jaxdc?")
    if version == 1:
        problem = meta.get("problem", "dcp" if meta.get("net") in DCP_NETS else "dcg")
        for key in OPTIONAL_SETTINGS.get(problem, ()):
            meta.setdefault(key, None)
        if isinstance(meta.get("algorithm"), dict):
            fields = algorithm_fields(meta.get("net"))
            meta["algorithm"] = {**fields, **{k: v for k, v in meta["algorithm"].items() if k in fields}}
    meta["format"] = FORMAT
    return meta


def check_run(meta: object, problem: str, where: str) -> dict:
    """A run's metadata (its ``config.json``) of ``problem`` in the current format, checked against the schema:
    an object of :data:`RUN_KEYS` only, of ``problem``, with ``net`` and an ``algorithm`` object holding only
    fields of the config that trains ``net``, and sensible values (:func:`check_values`). Each failure is a
    ``ValueError`` naming ``where``."""
    if not isinstance(meta, dict):
        raise ValueError(f"{where}: not a JSON object")
    try:
        meta = upgrade(meta)
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None
    stored = "dcg" if meta.get("problem") == "dcg" else "dcp"
    if stored != problem:
        raise ValueError(f"{where}: a {stored.upper()} run's config, not a {problem.upper()} run's")
    unknown = sorted(set(meta) - set(RUN_KEYS[problem]))
    if unknown:
        raise ValueError(f"{where}: keys no {problem.upper()} run writes: {', '.join(unknown)}")
    if "net" not in meta or not isinstance(meta.get("algorithm"), dict):
        raise ValueError(f"{where}: needs 'net' and an 'algorithm' object (a run folder's config.json)")
    if meta["net"] not in REGISTRIES[problem]:
        raise ValueError(f"{where}: net {meta['net']!r} is not one of the {problem.upper()} networks "
                         f"{tuple(REGISTRIES[problem])}")
    fields = algorithm_fields(meta["net"])
    unknown = sorted(set(meta["algorithm"]) - set(fields))
    if unknown:
        raise ValueError(f"{where}: 'algorithm' has fields no {_config_class(meta['net']).__name__} has: "
                         f"{', '.join(unknown)}")
    return check_values(meta, where)


def algorithm_config(net: str, algorithm: dict) -> Any:
    """The ``QConfig`` (n-step Q networks) or ``A2CConfig`` of ``net`` built from the ``algorithm`` record."""
    return _config_class(net)(**algorithm)


def recorded_pair(value: Any, key: str, where: str, meaning: str = "") -> tuple:
    """``value``, the pair ``key`` of a run's metadata (stored as a JSON list), as a tuple; otherwise a
    ``ValueError`` naming ``where`` (``meaning``, e.g. ``" [low, high]"``, ends the message)."""
    if not isinstance(value, list) or len(value) != 2:
        raise ValueError(f"{where}: {key}={value!r} must be a pair{meaning}")
    return tuple(value)


def run_settings(make: Callable[..., Any], meta: dict, where: str, **setting: Any) -> tuple[Any, tuple[int, ...]]:
    """``(settings, seeds)`` of a checked run's metadata ``meta`` (:func:`check_run`): ``make(net=...,
    config=..., **setting)`` with the config of its ``algorithm`` record, and its seeds; a value the settings
    refuse is a ``ValueError`` naming ``where``."""
    try:
        settings = make(net=meta["net"], config=algorithm_config(meta["net"], meta["algorithm"]), **setting)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: {e}") from None
    return settings, tuple(meta["seeds"]) if meta.get("seeds") else (meta.get("seed", 0),)
