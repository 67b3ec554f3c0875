"""Trained network parameters as small files: shipped with the package and exported from runs.

One parameter file is a single ``.msgpack`` (flax serialization of the
parameter pytree) with a JSON sidecar ``.json`` of metadata: its format
(``"format"``, :mod:`jaxdc.metadata`), the network name
(``"net"``) and the problem (``"problem"``: ``"dcp"`` or ``"dcg"``), plus
whatever the writer needs to rebuild the environment and to say how the file
was made (settings, steps, seed, the command that made it). Metadata of an
older format is upgraded on load (:func:`jaxdc.metadata.upgrade`), so
files of every format read the same.

The shipped files live in ``jaxdc/assets/<problem>/<name>.msgpack``;
:func:`shipped` finds one by name. :func:`load` checks the metadata against
what the caller expects and raises a ``ValueError`` naming the mismatch, so a
DCG file is never applied to a DCP network, nor an ENN file to EQN.
:class:`Learned` is the record both problems load into; each problem's
subclass adds how to read the setting of training from the metadata.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Collection
from typing import Any, Union

import jax
import jax.numpy as jnp
import numpy as np
from flax import serialization

from jaxdc.core.tree_check import non_finite, slash_path
from jaxdc.core.validate import INT32_MAX, check_choice, check_float, check_int
from jaxdc.io import atomic_write_set, json_text, read_json
from jaxdc.metadata import FORMAT, check_values, upgrade

#: ``check(name, value)``: the check of one metadata entry, strict about JSON types (a bool must be ``true`` or
#: ``false``, an int an integer); it returns the value or raises ``TypeError``/``ValueError`` naming ``name``.
SettingCheck = Callable[[str, Any], Any]
#: A file or folder path.
PathLike = Union[str, "os.PathLike[str]"]
#: ``restore_target(net_name, metadata, source)``: an initial training state shaped like a run's checkpoint.
RestoreTarget = Callable[[str, dict, str], Any]

ASSETS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "assets")


@dataclasses.dataclass(frozen=True)
class Learned:
    """A trained network with its parameters and the metadata of how it was trained (whatever the source).

    The interface both problems share: ``jaxdc.dcp.learned.Learned`` and
    ``jaxdc.dcg.learned.Learned`` subclass it with the problem's reading of the
    metadata, and each problem's module has ``load(path, ...)`` and
    ``shipped(...)`` returning one.
    """

    net_name: str
    net: Any  # a flax module (jaxdc.nets)
    params: Any
    metadata: dict
    source: str

    def setting(self) -> dict[str, Any]:
        """The environment setting of training (the problem's keys, defaults where not recorded)."""
        raise NotImplementedError

    def env_options(self) -> dict[str, Any]:
        """The environment constructor's options of training that change the dynamics (only those recorded)."""
        raise NotImplementedError

    def policy(self, *args: Any, greedy: bool = False, **kwargs: Any) -> Callable:
        """``policy(key, obs, state) -> action`` of the network for :func:`jaxdc.core.rollout.run_episodes`."""
        raise NotImplementedError

    def describe(self) -> str:
        """One line: network, training setting and source."""
        raise NotImplementedError


def json_bool(name: str, value: Any) -> bool:
    """A metadata flag: JSON ``true`` or ``false`` only (``"no"`` or ``0`` would read as a truth value)."""
    if not isinstance(value, bool):
        raise TypeError(f"{name} must be true or false (a JSON bool), got {value!r}")
    return value


def json_string(name: str, value: Any) -> str:
    """A metadata text: a non-empty JSON string."""
    if not isinstance(value, str) or not value:
        raise TypeError(f"{name} must be a non-empty string, got {value!r}")
    return value


def json_int(low: int, high: int | None = INT32_MAX) -> SettingCheck:
    """A metadata integer in ``[low, high]`` (``high=None``: unbounded); a float or a bool is refused."""
    return lambda name, value: check_int(name, value, low, high)


def json_number(low: float | None = None, high: float | None = None, low_open: bool = False,
                allow_inf: bool = False) -> SettingCheck:
    """A metadata number in range (:func:`jaxdc.core.validate.check_float`); with ``allow_inf`` the string
    ``"inf"`` (how jaxdc writes an unlimited budget) too."""
    def check(name: str, value: Any) -> float:
        if allow_inf and value == "inf":
            return float("inf")
        return check_float(name, value, low, high, low_open=low_open, allow_inf=allow_inf)
    return check


def json_choice(choices: Collection[str]) -> SettingCheck:
    """A metadata name, one of ``choices``."""
    def check(name: str, value: Any) -> str:
        if not isinstance(value, str):
            raise TypeError(f"{name} must be one of {tuple(choices)}, got {value!r}")
        return check_choice(name, value, tuple(choices))
    return check


def json_list(item: SettingCheck, length: int | None = None) -> SettingCheck:
    """A metadata list (of ``length`` items when given), each checked by ``item``."""
    def check(name: str, value: Any) -> list:
        if not isinstance(value, list) or (length is not None and len(value) != length):
            raise TypeError(f"{name} must be a list of {length or 'some'} values, got {value!r}")
        return [item(f"{name}[{i}]", v) for i, v in enumerate(value)]
    return check


def json_object(schema: dict[str, SettingCheck]) -> SettingCheck:
    """A metadata object whose entries of ``schema`` are checked (others are left alone)."""
    def check(name: str, value: Any) -> dict:
        if not isinstance(value, dict):
            raise TypeError(f"{name} must be a JSON object, got {value!r}")
        for key, item in schema.items():
            if key in value:
                item(f"{name}.{key}", value[key])
        return value
    return check


def optional(check: SettingCheck) -> SettingCheck:
    """``check``, or ``null`` (an unset optional setting)."""
    return lambda name, value: None if value is None else check(name, value)


def check_settings(meta: dict, where: str, schema: dict[str, SettingCheck]) -> dict:
    """``meta`` if every entry of ``schema`` present in it passes its check; else a ``ValueError`` that starts
    with ``where`` (the file) and the key: ``"<file>: key 'energy': ..."``."""
    for key, check in schema.items():
        if key in meta:
            try:
                check(key, meta[key])
            except (TypeError, ValueError) as e:
                raise ValueError(f"{where}: key {key!r}: {e}") from None
    return meta


def _paths(path: PathLike) -> tuple[str, str]:
    path = os.fspath(path)
    stem = path[: -len(".msgpack")] if path.endswith(".msgpack") else path
    return stem + ".msgpack", stem + ".json"


def non_finite_leaf(params: Any) -> str | None:
    """The ``/``-joined path of the first parameter array holding a NaN or an infinity, or ``None``
    (traced leaves, inside a jit, are skipped: they are checked where their values are known)."""
    bad = non_finite(params, key=slash_path)
    return bad[0][0] if bad else None


def save(path: PathLike, params: Any, metadata: dict) -> str:
    """Write ``params`` and ``metadata`` (JSON-able; must name ``net`` and ``problem``) atomically.

    Returns the ``.msgpack`` path. Both files are serialised first (the
    metadata as strict JSON, the parameters refused if any holds a NaN or an
    infinity), then land together (:func:`jaxdc.io.atomic_write_set`), so an
    error or an interruption leaves the old pair or the complete new one. The
    sidecar records the current ``"format"`` (:data:`jaxdc.metadata.FORMAT`).
    """
    for key in ("net", "problem"):
        if key not in metadata:
            raise ValueError(f"metadata must contain {key!r}, got keys {sorted(metadata)}")
    blob, meta = _paths(path)
    tree = jax.tree_util.tree_map(np.asarray, jax.device_get(params))
    bad = non_finite_leaf(tree)
    if bad is not None:
        raise ValueError(f"refusing to save {blob}: parameter {bad} holds NaN or infinity")
    try:
        meta_text = json_text({"format": FORMAT, **{k: v for k, v in metadata.items() if k != "format"}}) + "\n"
    except ValueError as e:
        raise ValueError(f"refusing to save {blob}: its metadata: {e}") from None
    except TypeError as e:
        raise ValueError(f"refusing to save {blob}: its metadata is not JSON-able: {e}") from None
    atomic_write_set({blob: serialization.msgpack_serialize(serialization.to_state_dict(tree)), meta: meta_text})
    return blob


def check_metadata_values(meta: dict, where: str) -> dict:
    """``meta`` if its settings have sensible types and ranges (:func:`jaxdc.metadata.check_values`)."""
    return check_values(meta, where)


def read_metadata(path: PathLike) -> dict:
    """The metadata sidecar of the parameter file ``path``, in the current format.

    The sidecar must be strict JSON (no NaN or Infinity) and its settings sensible
    (:func:`check_metadata_values`); each failure is a ``ValueError`` naming the file (and the key).
    """
    blob, meta = _paths(path)
    if os.path.isdir(meta):
        raise ValueError(f"parameter file {blob}: metadata {meta} is a folder, not a JSON file")
    if not os.path.isfile(meta):
        raise ValueError(f"parameter file {blob}: metadata {meta} not found (was it written by jaxdc.pretrained.save?)")
    try:
        stored = read_json(meta)
    except ValueError as e:
        raise ValueError(f"parameter file {blob}: metadata unreadable: {e}") from None
    if not isinstance(stored, dict):
        raise ValueError(f"parameter file {blob}: metadata {meta} must be a JSON object, got {type(stored).__name__}")
    try:
        return check_metadata_values(upgrade(stored), f"parameter file {blob} ({meta})")
    except ValueError as e:
        raise ValueError(f"parameter file {blob}: {e}" if blob not in str(e) else str(e)) from None


def load(path: PathLike, **expected: Any) -> tuple[dict, dict]:
    """``(params, metadata)`` of the parameter file ``path``.

    Every keyword of ``expected`` (e.g. ``net="enn", problem="dcp"``) must equal
    the stored metadata entry, else a ``ValueError`` names the key and both values.
    Parameters holding a NaN or an infinity are refused (a ``ValueError`` naming
    the file and the first such parameter).
    """
    blob, _ = _paths(path)
    meta = read_metadata(path)
    for key, want in expected.items():
        if meta.get(key) != want:
            raise ValueError(f"parameter file {blob} has {key}={meta.get(key)!r}, expected {want!r}")
    try:
        with open(blob, "rb") as f:
            params = serialization.msgpack_restore(f.read())
    except Exception as e:  # msgpack raises several types on a damaged file
        raise ValueError(f"parameter file {blob} unreadable (corrupt or truncated?): {e}") from None
    check_finite(params, f"parameter file {blob}")
    return params, meta


def shipped(problem: str, name: str) -> str:
    """Path of the shipped parameter file ``name`` of ``problem`` (``jaxdc/assets/<problem>/<name>.msgpack``)."""
    folder = os.path.join(ASSETS, problem)
    path = os.path.join(folder, name + ".msgpack")
    if not os.path.isfile(path):
        have = sorted(f[: -len(".msgpack")] for f in os.listdir(folder) if f.endswith(".msgpack")) \
            if os.path.isdir(folder) else []
        raise ValueError(f"no shipped {problem} parameters named {name!r}; available: {have}")
    return path


def shipped_names(problem: str) -> list[str]:
    """Names of the shipped parameter files of ``problem`` (``jaxdc/assets/<problem>/*.msgpack``)."""
    folder = os.path.join(ASSETS, problem)
    if not os.path.isdir(folder):
        return []
    return sorted(f[: -len(".msgpack")] for f in os.listdir(folder) if f.endswith(".msgpack"))


def resolve(path: PathLike, problem: str) -> str:
    """``path`` itself if it exists (a parameter file, with or without ``.msgpack``, or a run folder); else, for a
    bare name such as ``enn`` or ``omn_conn_strong``, the shipped file ``jaxdc/assets/<problem>/<name>.msgpack``.

    A bare name that is no shipped network is a ``ValueError`` listing the shipped names.
    """
    path = os.fspath(path)
    blob, _ = _paths(path)
    if os.path.exists(path) or os.path.isfile(blob):
        return path
    name = path[: -len(".msgpack")] if path.endswith(".msgpack") else path
    if name and os.sep not in name and (os.altsep is None or os.altsep not in name):
        shipped_path = os.path.join(ASSETS, problem, name + ".msgpack")
        if os.path.isfile(shipped_path):
            return shipped_path
        raise ValueError(f"{path!r} is neither a file, a run folder nor a shipped {problem} network; "
                         f"shipped: {', '.join(shipped_names(problem))}")
    return path


def read_paths(path: PathLike, problem: str) -> list[str]:
    """The files and folders :func:`load_trained` reads for ``path``: a parameter file and its sidecar, or a run
    folder's ``checkpoints/`` and ``config.json`` (for the commands' check that no output overwrites an input)."""
    try:
        path = resolve(path, problem)
    except ValueError:
        path = os.fspath(path)
    if os.path.isdir(path):
        ckpt = os.path.join(path, "checkpoints")
        return [ckpt, os.path.join(path, "config.json")] if os.path.isdir(ckpt) else [path]
    return list(_paths(path))


def check_finite(params: Any, source: str) -> None:
    """``ValueError`` naming ``source`` and the first parameter that holds NaN or infinity (a damaged file or a
    diverged run); every loader of trained parameters calls it."""
    bad = non_finite_leaf(params)
    if bad is not None:
        raise ValueError(f"{source}: parameter {bad} holds NaN or infinity; the file is damaged or "
                         "was saved from a diverged run")


def _naming_source(restore_target: RestoreTarget, source: str) -> RestoreTarget:
    """``restore_target`` whose ``ValueError``/``TypeError`` (a bad setting in the metadata) names ``source``."""
    def target(*args: Any) -> Any:
        try:
            return restore_target(*args)
        except (ValueError, TypeError) as e:
            raise ValueError(f"{source}: its metadata does not build a network: {e}") from None

    return target


def load_trained(path: PathLike, problem: str, nets: Collection[str], restore_target: RestoreTarget,
                 net: str | None = None, check_meta: Callable[[dict, str], None] | None = None,
                 run_seed: int | None = None,
                 check_setting: Callable[[dict, str], None] | None = None) -> tuple[str, Any, dict, str]:
    """``(net_name, params, metadata, source)`` of a trained network, from a file or a training run.

    ``path`` is a parameter file of :func:`save` (``.msgpack``, suffix
    optional), a shipped network's name (:func:`resolve`) or a run folder of ``python -m train.<problem>`` (its
    ``checkpoints/`` subfolder, or an orbax checkpoint folder itself; the latest
    step is read). The stored ``problem`` must be ``problem``, the stored
    network one of ``nets`` and, if given, ``net``; ``check_setting(meta, where)`` checks the stored setting
    (``where``: the sidecar file, or the run's checkpoint metadata, for its messages) before anything is built
    from it, and ``check_meta(meta, source)`` may refuse more (e.g. another grid size). A run's parameters are restored
    into ``restore_target(name, meta, source)``, an initial training state of the
    same structure; its metadata gets ``updates``, the restored checkpoint's
    update count. A run of several seeds (``--seeds 0,1,2``: every array has a
    leading seed axis) needs ``run_seed``, the seed whose parameters to return.
    Each failure is a ``ValueError`` that names the source.
    """
    from jaxdc import checkpoint

    path = resolve(path, problem)
    if os.path.isdir(path):
        ckpt = os.path.join(path, "checkpoints")
        ckpt = ckpt if os.path.isdir(ckpt) else path
        source = f"checkpoint {path!r}"
        if not checkpoint.steps(ckpt):
            raise ValueError(f"{source}: no orbax checkpoint found (expected a train.{problem} run folder "
                             "with checkpoints/, or a .msgpack parameter file)")
        try:
            meta = upgrade(dict(checkpoint.read_metadata(ckpt), problem=problem))
        except ValueError as e:
            raise ValueError(f"{source}: {e}") from None
        where = f"{source} (checkpoint metadata)"
        check_metadata_values(meta, where)
    else:
        blob, _ = _paths(path)
        if not os.path.isfile(blob):
            raise ValueError(f"checkpoint {path!r} not found: expected a train.{problem} run folder or a .msgpack "
                             "parameter file (jaxdc.pretrained)")
        source = f"parameter file {blob}"
        where = _paths(blob)[1]
        meta = read_metadata(blob)
        if meta.get("problem") != problem:
            raise ValueError(f"{source} is for problem {meta.get('problem')!r}, not {problem!r}")
    name = meta.get("net")
    if not isinstance(name, str) or name not in nets:
        raise ValueError(f"{source}: metadata names net {name!r}, not one of the {problem} networks {tuple(nets)}")
    if net is not None and name != net:
        raise ValueError(f"{source} holds a {name!r} network, not {net!r}")
    if check_setting is not None:
        check_setting(meta, where)
    if check_meta is not None:
        check_meta(meta, source)
    restore_target = _naming_source(restore_target, source)
    seeds = meta.get("seeds")
    if not seeds and run_seed is not None and run_seed != meta.get("seed", run_seed):
        raise ValueError(f"{source} holds the network of seed {meta.get('seed')}, not of run_seed {run_seed}")
    if os.path.isdir(path):
        if not seeds:
            target = restore_target(name, meta, source)
            try:
                state, meta = checkpoint.restore(ckpt, target, {"net": name}, upgrade=upgrade)
                check_finite(state.params, source)
            except ValueError as e:  # the latest step is damaged: name the intact ones, as train --resume does
                latest = checkpoint.latest_step(ckpt)
                skip = () if latest is None else (latest,)
                intact = checkpoint.intact_steps(ckpt, target, {"net": name}, upgrade=upgrade, exclude=skip)
                raise ValueError(f"{e}. " + (
                    f"Intact checkpoints: steps {intact}; a run folder is read at its latest step, so continue the "
                    f"run from one (train.{problem} --out {path} --resume --resume-step {intact[-1]}: the later "
                    "checkpoints are deleted) or use another run" if intact else
                    "No other checkpoint of the run is intact")) from None
            return name, state.params, dict(meta, problem=problem, updates=checkpoint.latest_step(ckpt)), ckpt
        if run_seed not in seeds:
            raise ValueError(f"{source} holds the runs of seeds {seeds}: choose one with run_seed "
                             f"(eval.dcp's and eval.dcg's --run-seed), got {run_seed}")
        target = jax.tree_util.tree_map(lambda x: jnp.stack([x] * len(seeds)),
                                        restore_target(name, meta, source))
        state, meta = checkpoint.restore(ckpt, target, {"net": name}, upgrade=upgrade)
        i = seeds.index(run_seed)
        params = jax.tree_util.tree_map(lambda x: x[i], state.params)
        check_finite(params, f"{source} (seed {run_seed})")
        meta = {k: v for k, v in meta.items() if k != "seeds"}
        return name, params, dict(meta, seed=run_seed, problem=problem, updates=checkpoint.latest_step(ckpt)), ckpt
    params, meta = load(blob, problem=problem, net=name)
    return name, params, meta, blob
