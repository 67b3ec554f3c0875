"""Orbax checkpoints of a training state, with metadata that is checked on restore.

A checkpoint folder holds numbered steps (the last ``keep`` are kept), each
with the state (any pytree of arrays, stored as its flax state dict) and a
JSON ``metadata`` dict (network name, grid size, configuration, ...).
:func:`restore` refuses, with a ``ValueError`` that names the problem, a
checkpoint whose metadata differs from what the caller expects (another
network or environment shape), whose arrays do not match the expected
shapes, or that cannot be read. Saving is synchronous, so a checkpoint that
``save`` returned from is complete; orbax writes each step to a temporary
folder and renames it when done, so a killed run leaves the previous
checkpoints intact.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import time
from collections.abc import Callable
from typing import Any, Union

import jax
import numpy as np
import orbax.checkpoint as ocp
from flax import serialization

from jaxdc.core.tree_check import mismatch

#: A folder path.
PathLike = Union[str, "os.PathLike[str]"]


def _manager(directory: PathLike, keep: int | None = None) -> ocp.CheckpointManager:
    path = os.path.abspath(os.fspath(directory))
    if jax.process_count() == 1:
        options = ocp.CheckpointManagerOptions(max_to_keep=keep, enable_async_checkpointing=False, create=True)
    else:  # several processes (jaxdc.training.distributed): each call is this process's alone, no barriers
        me = jax.process_index()
        os.makedirs(path, exist_ok=True)
        options = ocp.CheckpointManagerOptions(
            max_to_keep=keep, enable_async_checkpointing=False, create=False,
            multiprocessing_options=ocp.options.MultiprocessingOptions(primary_host=me, active_processes={me}))
    return ocp.CheckpointManager(path, options=options)


def save(directory: PathLike, step: int, state: Any, metadata: dict, keep: int = 3) -> None:
    """Write ``state`` (a pytree) and ``metadata`` (JSON-able) as checkpoint ``step``; keep the last ``keep``."""
    tree = serialization.to_state_dict(jax.device_get(state))
    with _manager(directory, keep) as mngr:
        mngr.save(int(step), args=ocp.args.Composite(state=ocp.args.StandardSave(tree),
                                                     metadata=ocp.args.JsonSave(dict(metadata))))
        mngr.wait_until_finished()


def steps(directory: PathLike) -> list[int]:
    """The checkpoint steps in ``directory`` (empty if there is none or no folder)."""
    if not os.path.isdir(os.fspath(directory)):
        return []
    with _absl_quiet(), _manager(directory) as mngr:
        return sorted(mngr.all_steps())


@contextlib.contextmanager
def _absl_quiet():
    """Hold back orbax's log lines about a damaged step (the ``ValueError`` of the caller says it once)."""
    absl = logging.getLogger("absl")
    level = absl.level
    absl.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        absl.setLevel(level)


def latest_step(directory: PathLike) -> int | None:
    s = steps(directory)
    return s[-1] if s else None


def read_metadata(directory: PathLike, step: int | None = None) -> dict:
    """The metadata of checkpoint ``step`` (default: the latest)."""
    step = _pick(directory, step)
    try:
        with _absl_quiet(), _manager(directory) as mngr:
            return dict(mngr.restore(step, args=ocp.args.Composite(metadata=ocp.args.JsonRestore())).metadata)
    except Exception as e:  # orbax raises many types for a damaged folder
        raise ValueError(f"checkpoint {directory} step {step}: metadata unreadable (corrupt?): {_first_line(e)}") \
            from None


def restore(directory: PathLike, target: Any, expected: dict | None = None, step: int | None = None,
            upgrade: Callable[[dict], dict] | None = None) -> tuple[Any, dict]:
    """Restore checkpoint ``step`` (default: latest) into the structure of ``target``: ``(state, metadata)``.

    ``expected`` holds metadata entries that must match exactly (e.g. the
    network name and grid size); every array must have ``target``'s shape
    and dtype. ``upgrade`` (e.g. :func:`jaxdc.metadata.upgrade`)
    turns the stored metadata into the current format before it is compared
    and returned.
    """
    step = _pick(directory, step)
    metadata = read_metadata(directory, step)
    if upgrade is not None:
        metadata = upgrade(metadata)
    mismatched = [d for k, v in (expected or {}).items()
                  for d in _differences(k, metadata.get(k, _MISSING), v)]
    if mismatched:
        what = "; ".join(f"{k}: checkpoint has {_show(a)}, this run has {_show(b)}" for k, a, b in mismatched)
        raise ValueError(f"checkpoint {directory} step {step} does not fit this run ({what})")
    template = serialization.to_state_dict(jax.device_get(target))
    try:
        with _manager(directory) as mngr:
            tree = mngr.restore(step, args=ocp.args.Composite(state=ocp.args.StandardRestore())).state
    except Exception as e:
        _settle_failed_restore()
        raise ValueError(f"checkpoint {directory} step {step}: state unreadable (corrupt?): {_first_line(e)}") \
            from None
    _check_state(tree, template, f"checkpoint {directory} step {step}")
    tree = jax.tree_util.tree_map(lambda t, x: np.asarray(x, dtype=np.asarray(t).dtype), template, tree)
    return serialization.from_state_dict(target, tree), metadata


#: How long a failed restore waits for orbax's outstanding reads to finish (seconds of quiet, at most).
_QUIET_S, _SETTLE_MAX_S = 0.3, 5.0


class _Sink:
    """A stand-in ``sys.stderr`` that swallows and timestamps what is written to it."""

    def __init__(self) -> None:
        self.last = time.monotonic()

    def write(self, text: str) -> int:
        self.last = time.monotonic()
        return len(text)

    def flush(self) -> None:
        pass


def _settle_failed_restore() -> None:
    """After a failed restore, let orbax's other outstanding array reads finish while their
    ``RuntimeError: Event loop is closed`` reports (printed from background threads, since orbax's event
    loop closed with the first error) are swallowed, so the caller's one clear error is all that is shown."""
    sink, previous, previous_hook = _Sink(), sys.stderr, sys.unraisablehook
    sys.stderr = sink
    sys.unraisablehook = lambda unraisable: sink.write("unraisable")  # the reports arrive as unraisable errors
    start = time.monotonic()
    try:
        while time.monotonic() - sink.last < _QUIET_S and time.monotonic() - start < _SETTLE_MAX_S:
            time.sleep(0.05)
    finally:
        sys.stderr, sys.unraisablehook = previous, previous_hook


def _first_line(e: BaseException) -> str:
    """An error's first line, without tensorstore's spec dump."""
    text = str(e).split("\n")[0]
    return text.split(" [tensorstore_spec=")[0]


def _pick(directory, step):
    available = steps(directory)
    if not available:
        raise ValueError(f"no checkpoint found in {directory}")
    if step is None:
        return available[-1]
    if step not in available:
        raise ValueError(f"checkpoint step {step} not in {directory} (available: {available})")
    return int(step)


_MISSING = "<missing>"


def _show(x) -> str:
    return x if x is _MISSING else repr(x)


def _differences(key: str, stored, wanted) -> list[tuple[str, Any, Any]]:
    """``(key path, stored, wanted)`` of each entry that differs; dicts are compared key by key."""
    if isinstance(stored, dict) and isinstance(wanted, dict):
        return [d for k in list(stored) + [k for k in wanted if k not in stored]
                for d in _differences(f"{key}.{k}", stored.get(k, _MISSING), wanted.get(k, _MISSING))]
    return [] if _jsonish(stored) == _jsonish(wanted) else [(key, stored, wanted)]


def _jsonish(x):
    """Compare JSON-restored values with Python ones (tuples become lists)."""
    if isinstance(x, (list, tuple)):
        return [_jsonish(v) for v in x]
    if isinstance(x, dict):
        return {k: _jsonish(v) for k, v in x.items()}
    return x


def _slash_path(path) -> str:
    """A state-dict leaf path as ``/key/key``."""
    return "".join(f"/{getattr(k, 'key', k)}" for k in path)


def _check_state(tree, template, where: str):
    """``ValueError`` unless the restored state dict ``tree`` has the leaves and shapes of ``template``."""
    m = mismatch(template, tree, key=_slash_path)
    if m is not None and m.key is None:
        raise ValueError(f"{where} has another structure (missing {m.missing[:5]}, unexpected {m.unexpected[:5]})")
    if m is not None:
        raise ValueError(f"{where}: {m.key} has shape {m.got}, expected {m.want}")
