"""Named training configurations, and a run's own ``config.json``, as the flags of ``train.dcp`` / ``train.dcg``.

``python -m train.dcp --config NAME`` (or ``train.dcg``) trains with the
named configuration: the recipe of a shipped network (the presets of
:mod:`jaxdc.training.ship`, which ``train.ship`` runs: one source for both).
``--config runs/x/config.json`` retrains the run whose folder holds that
file: its metadata (:func:`jaxdc.training.dcp.run_metadata`,
:func:`jaxdc.training.dcg.run_metadata`) becomes the flags that wrote it.

Either way the configuration is turned into command-line flags placed
*before* the ones given, so every value goes through the same argparse checks
as a typed flag, and a flag given explicitly overrides the configuration's
(``--config enn --steps 20000``). A switch the configuration turns on
(``--normalize-advantages``) cannot be turned off again.

A run's ``config.json`` records what shapes the trained parameters (the
environment, the algorithm and the seed); the evaluation cadence
(``--eval-every``, ``--eval-episodes``, ``--greedy-eval``), the output folder
and the progress bar are not recorded and take their defaults unless given.
"""

from __future__ import annotations

import json
import os
from typing import NamedTuple

from jaxdc.training.metadata import upgrade
from jaxdc.training.ship import DCG_STRONG, EVERY


class Config(NamedTuple):
    """A named configuration: its problem, what it trains (the tables or figures it fills) and its flags."""

    problem: str  # "dcp" or "dcg"
    description: str
    flags: tuple


#: The named configurations: every preset of :mod:`jaxdc.training.ship` (the shipped networks' recipes).
CONFIGS = {name: Config("dcg" if name in DCG_STRONG else "dcp", desc, tuple(flags))
           for name, (desc, flags) in EVERY.items()}

#: Metadata keys of a DCP run's ``config.json`` and the flag each becomes (``None``: read elsewhere or ignored).
DCP_KEYS = {"format": None, "problem": None, "net": "--net", "grid_size": "--grid-size",
            "total_reward": "--total-reward", "risk": "--risk", "energy": "--energy", "max_steps": "--max-steps",
            "min_total_reward": "--min-total-reward", "seed": "--seed", "seeds": "--seeds", "algorithm": None}
#: The same for a DCG run.
DCG_KEYS = {"format": None, "problem": None, "net": "--net", "grid_size": "--grid-size",
            "total_reward": "--total-reward", "strategies": "--strategies", "energy": "--energy",
            "max_steps": "--max-steps", "history": "--history", "alpha": "--alpha", "reward_area": "--reward-area",
            "min_reward_area": "--min-reward-area", "seed": "--seed", "seeds": "--seeds", "algorithm": None}


def names(problem: str) -> list[str]:
    """The names of ``problem``'s configurations."""
    return [n for n, c in CONFIGS.items() if c.problem == problem]


def listing(problem: str) -> str:
    """One line per named configuration of ``problem``: its name and what it trains."""
    return "\n".join(f"{n:22s} {CONFIGS[n].description}" for n in names(problem))


def _value(v) -> list[str]:
    if isinstance(v, bool):
        raise TypeError
    if isinstance(v, (list, tuple)):
        return [str(x) for x in v]
    return [f"{v:g}" if isinstance(v, float) else str(v)]


def _algorithm_flags(algo: dict, problem: str, net: str, where: str) -> list[str]:
    """The flags of an ``algorithm`` record (``A2CConfig``/``QConfig`` fields); a field no flag sets must hold its
    default."""
    from jaxdc.agents.a2c import A2CConfig
    from jaxdc.agents.nstep_q import QConfig
    from jaxdc.cli.train_common import A2C_FLAGS, flag

    cls = QConfig if net == "eqn" else A2CConfig
    defaults = {f: getattr(cls(), f) for f in cls.__dataclass_fields__}
    unknown = sorted(set(algo) - set(defaults))
    if unknown:
        raise ValueError(f"{where}: 'algorithm' has fields no {cls.__name__} has: {', '.join(unknown)}")
    own = {"target_every": "--target-every"}
    if problem == "dcg":
        own["aux_lr"] = "--omn-lr"
    out = []
    for field, v in algo.items():
        name = flag(field) if field in A2C_FLAGS else own.get(field)
        if field == "aux_coef" and problem == "dcg":
            continue  # set by --net and --alpha (EMNN's weight; 1 for OMN + CoNN)
        if name is None:
            if v != defaults[field]:
                raise ValueError(f"{where}: algorithm field {field}={v!r} is set by no flag of train.{problem} "
                                 f"(its default is {defaults[field]!r})")
            continue
        if v is None:
            continue
        if isinstance(v, bool):
            out += [name] if v else []
        else:
            out += [name, *_value(v)]
    return out


def run_flags(meta: dict, problem: str, where: str) -> list[str]:
    """The flags that retrain the run of ``meta`` (a ``config.json``); ``ValueError`` naming ``where`` for a file of
    the other problem or with keys no run writes."""
    if not isinstance(meta, dict):
        raise ValueError(f"{where}: not a JSON object")
    try:
        meta = upgrade(meta)
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None
    is_dcg = meta.get("problem") == "dcg"
    if is_dcg != (problem == "dcg"):
        other = "dcg" if is_dcg else "dcp"
        raise ValueError(f"{where}: a {other.upper()} run's config; use python -m train.{other} --config")
    keys = DCG_KEYS if problem == "dcg" else DCP_KEYS
    unknown = sorted(set(meta) - set(keys))
    if unknown:
        raise ValueError(f"{where}: keys no train.{problem} run writes: {', '.join(unknown)}")
    if "net" not in meta or not isinstance(meta.get("algorithm"), dict):
        raise ValueError(f"{where}: needs 'net' and an 'algorithm' object (a run folder's config.json)")
    out = []
    for key, name in keys.items():
        v = meta.get(key)
        if name is None or v is None or (key == "history" and v == 0):
            continue
        try:
            if key in ("strategies", "seeds"):
                vals = [",".join(map(str, v))] if isinstance(v, list) else _value(v)
            else:
                vals = _value(v)  # a list (the DCP's energy pair) gives one word per value
        except TypeError:
            raise ValueError(f"{where}: {key} must be a number, text or a list of them, got {v!r}") from None
        out += [name, *vals]
    return out + _algorithm_flags(meta["algorithm"], problem, meta["net"], where)


def expand(argv: list[str], problem: str) -> list[str]:
    """``argv`` with its ``--config NAME|FILE`` replaced by the configuration's flags, placed first (so the flags
    given override them). ``ValueError`` for an unknown name, a file that is not a run's ``config.json`` or a
    configuration of the other problem."""
    argv = list(argv)
    found = [i for i, a in enumerate(argv) if a == "--config" or a.startswith("--config=")]
    if not found:
        return argv
    if len(found) > 1:
        raise ValueError("--config given more than once")
    i = found[0]
    if argv[i] == "--config":
        if i + 1 >= len(argv):
            raise ValueError("--config needs a NAME or a run's config.json")
        value, rest = argv[i + 1], argv[:i] + argv[i + 2:]
    else:
        value, rest = argv[i].split("=", 1)[1], argv[:i] + argv[i + 1:]
    return config_flags(value, problem) + rest


def _refuse_constant(name):
    raise ValueError(f"{name} is not strict JSON")


def config_flags(value: str, problem: str) -> list[str]:
    """The flags of configuration ``value``: a name of :data:`CONFIGS` or the path of a run's ``config.json``."""
    if value in CONFIGS:
        c = CONFIGS[value]
        if c.problem != problem:
            raise ValueError(f"--config {value!r} is a {c.problem.upper()} configuration; use "
                             f"python -m train.{c.problem} --config {value}")
        return list(c.flags)
    path = os.path.join(value, "config.json") if os.path.isdir(value) else value
    if not os.path.isfile(path):
        raise ValueError(f"--config {value!r} is neither a named configuration ({', '.join(names(problem))}) "
                         "nor a run's config.json")
    try:
        with open(path) as f:
            meta = json.load(f, parse_constant=_refuse_constant)
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise ValueError(f"--config {path}: not a readable JSON file ({e})") from None
    return run_flags(meta, problem, f"--config {path}")
