"""File output: atomic writes, sets of files that land together, and strict JSON.

A run killed half-way (Ctrl-C included) never leaves a half-written result:
every file is written to a temporary file in the same folder, then renamed.
:func:`atomic_write_set` writes several files (a table's ``.json`` and
``.md``) so that either all the old ones or all the new ones are there;
:func:`signals_deferred` holds a Ctrl-C or SIGTERM until a write ends.
Every JSON jaxdc writes is strict (:func:`json_text`): NaN and Infinity,
which JSON does not have, are refused with the key path that holds them, so
a producer writes ``null`` and a reason instead.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import signal
import tempfile
import threading
from collections.abc import Iterable, Iterator, Mapping, Sequence
from typing import Union


def _write_temp(path: str, data: bytes | str) -> str:
    """Write ``data`` to a new temporary file beside ``path`` (with the mode ``open`` would give); its name."""
    folder = os.path.dirname(path) or "."
    os.makedirs(folder, exist_ok=True)
    # the temporary name keeps the target's name (a long one shortened: the file system's limit applies to it too)
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=os.path.basename(path)[-(NAME_MAX - 32):])
    try:
        # mkstemp creates 0600; give the result the mode open() would (0666 minus the umask).
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
    except BaseException:
        os.unlink(tmp)
        raise
    return tmp


def atomic_write(path, data: bytes | str) -> str:
    """Write ``data`` to ``path`` atomically (same-directory temp file, then ``os.replace``)."""
    return atomic_write_set({path: data})[0]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def non_finite_paths(obj, prefix: str = "") -> list[str]:
    """Key paths (``a.b[2]``) of the NaN and infinite floats inside ``obj`` (dicts, lists, tuples, numbers)."""
    if isinstance(obj, float):
        return [] if math.isfinite(obj) else [prefix or "<top>"]
    if isinstance(obj, dict):
        return [p for k, v in obj.items() for p in non_finite_paths(v, f"{prefix}.{k}" if prefix else str(k))]
    if isinstance(obj, (list, tuple)):
        return [p for i, v in enumerate(obj) for p in non_finite_paths(v, f"{prefix}[{i}]")]
    return []


def json_text(obj, indent: int | None = 2) -> str:
    """``obj`` as strict JSON text (``allow_nan=False``); a NaN or infinity raises ``ValueError`` naming where."""
    try:
        return json.dumps(obj, indent=indent, sort_keys=False, allow_nan=False)
    except ValueError:
        where = ", ".join(non_finite_paths(obj)[:5]) or "?"
        raise ValueError(f"refusing to write NaN or Infinity into JSON (at {where}); "
                         f"an undefined value must be written as null") from None


def _refuse_constant(path: str):
    def refuse(constant):
        raise ValueError(f"{path}: holds {constant}, which strict JSON does not have")
    return refuse


def read_json(path: str, hint: str = "") -> object:
    """The strict JSON in the file ``path`` (NaN and Infinity refused): every reader of a JSON file uses this one.

    An unreadable file, one that is not JSON, or one holding NaN/Infinity gives a ``ValueError`` that names
    ``path``; ``hint`` (e.g. ``"rerun the command that wrote it"``) is appended to the message.
    """
    tail = f"; {hint}" if hint else ""
    try:
        with open(path) as f:
            return json.load(f, parse_constant=_refuse_constant(path))
    except (OSError, UnicodeDecodeError) as e:
        raise ValueError(f"{path}: cannot read it: {e}") from None
    except RecursionError:
        raise ValueError(f"{path}: nested too deeply to be read{tail}") from None
    except ValueError as e:
        if str(e).startswith(path):
            raise
        raise ValueError(f"{path}: not valid JSON ({e}){tail}") from None


def finite_or_none(x):
    """``x`` as a float, or ``None`` when it is NaN or infinite (for a statistic that is undefined)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def unlimited_to_json(x):
    """A setting that may be unlimited (an energy budget) as JSON: the number, or the string ``"inf"``.

    JSON has no infinity; ``"inf"`` reads back with ``float("inf")``. A NaN is refused (it is no setting).
    """
    if isinstance(x, (list, tuple)):
        return [unlimited_to_json(v) for v in x]
    x = float(x)
    if math.isnan(x):
        raise ValueError("a setting cannot be NaN")
    return "inf" if x == math.inf else x


def atomic_write_json(path, obj) -> str:
    """``atomic_write`` of ``obj`` as indented strict JSON (:func:`json_text`)."""
    return atomic_write(path, json_text(obj) + "\n")


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM until the block ends, then deliver them (each once, in the order they came, to the
    handlers that were set before the block; a handler that raises, as Ctrl-C's does, ends the delivery), so that
    the block runs to completion: a Ctrl-C during a checkpoint's write stops the run
    after the write, never inside the checkpointing library's threads.

    The handlers are swapped, not the thread's signal mask: in a process with other threads (JAX's, a checkpoint
    writer's) a signal blocked in the main thread is still delivered through another one. Signal handlers run in
    the main thread only, so elsewhere, and for a signal whose handler was not set from Python, the block runs
    unprotected."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    held = [s for s, handler in previous.items() if handler is not None]
    caught: list[int] = []
    for s in held:
        signal.signal(s, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        for s in held:
            signal.signal(s, previous[s])
        for s in dict.fromkeys(caught):
            signal.raise_signal(s)


def atomic_write_set(files: dict) -> list[str]:
    """Write several files so that they land together: ``{path: text or bytes}``.

    Every file is first written to a temporary file beside it; the renames
    then run with SIGINT/SIGTERM held, so an interruption leaves either the
    old set or the complete new one (never a new ``.json`` beside an old
    ``.md``). Returns the paths.
    """
    temps = []
    try:
        for path, data in files.items():
            path = os.fspath(path)
            temps.append((_write_temp(path, data), path))
        with signals_deferred():
            for tmp, path in temps:
                os.replace(tmp, path)
    except BaseException:
        for tmp, _ in temps:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise
    return [path for _, path in temps]


#: The inputs of a command, for the overwrite check: ``{flag: path, paths or None}`` (``None`` entries skipped).
Inputs = Mapping[str, Union[str, "os.PathLike[str]", Sequence[Union[str, "os.PathLike[str]"]], None]]

#: The longest file name most file systems take (bytes), where ``pathconf`` cannot say.
NAME_MAX = 255


def _name_max(folder: str) -> int:
    probe = _nearest_existing(folder)
    try:
        return int(os.pathconf(probe, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return NAME_MAX


def _nearest_existing(path: str) -> str:
    probe = path
    while not os.path.lexists(probe):  # the nearest existing ancestor decides
        parent = os.path.dirname(probe)
        if parent == probe:
            break
        probe = parent
    return probe


def _check_shape(path: str, what: str) -> None:
    """Refuse a path that no write can create: empty, a component longer than the file system's limit, a
    dangling symbolic link on the way (``os.makedirs`` and ``open`` would fail only after the work)."""
    if not path:
        raise ValueError(f"{what} is empty; give a path")
    if "\x00" in path:
        raise ValueError(f"{what} {path!r} holds a NUL character")
    absolute = os.path.abspath(path)
    limit = _name_max(os.path.dirname(absolute))
    for part in absolute.split(os.sep):
        if len(os.fsencode(part)) > limit:
            raise ValueError(f"{what} {path!r}: the name {part[:40]!r}... is {len(os.fsencode(part))} bytes long, "
                             f"more than the file system's limit of {limit}")
    probe = absolute
    while True:
        if os.path.islink(probe) and not os.path.exists(probe):
            raise ValueError(f"{what} {path!r}: {probe!r} is a symbolic link to {os.readlink(probe)!r}, "
                             "which does not exist")
        parent = os.path.dirname(probe)
        if parent == probe:
            break
        probe = parent


def _paths_of(given) -> list[str]:
    if given is None:
        return []
    if isinstance(given, (str, os.PathLike)):
        return [os.fspath(given)]
    return [os.fspath(p) for p in given if p is not None]


def _same_file(a: str, b: str) -> bool:
    """Whether ``a`` and ``b`` name one file: the same resolved path (symbolic links followed) or, when both
    exist, the same inode (hard links)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _inside(path: str, folder: str) -> bool:
    real, top = os.path.realpath(path), os.path.realpath(folder)
    return real != top and real.startswith(top.rstrip(os.sep) + os.sep)


def check_not_input(path, what: str, inputs: Inputs | None) -> None:
    """Refuse an output ``path`` that resolves to one of ``inputs`` (symbolic and hard links included) or lies
    inside an input folder: the command would overwrite what it reads. ``ValueError`` naming both flags."""
    path = os.fspath(path)
    for flag, given in (inputs or {}).items():
        for source in _paths_of(given):
            if _same_file(path, source) or (os.path.isdir(source) and _inside(path, source)):
                raise ValueError(f"{what} {path!r} would overwrite the input {flag} {source!r}; "
                                 "write the output somewhere else")


def check_output_path(path, what: str = "output", inputs: Inputs | None = None) -> str:
    """Refuse, before any work, a file path that cannot be written or must not be: a folder at the name, its
    folder a file or not writable, a dangling symbolic link on the way, a name longer than the file system
    takes, or one of the command's ``inputs`` (:func:`check_not_input`).

    Creates nothing. Returns the path. ``ValueError`` names the path and the reason.
    """
    path = os.fspath(path)
    _check_shape(path, what)
    if os.path.isdir(path):
        raise ValueError(f"{what} {path!r} is a folder, not a file")
    _check_folder(os.path.dirname(os.path.abspath(path)), what, path)
    check_not_input(path, what, inputs)
    return path


def check_output_folder(folder, what: str = "output folder", files: Iterable[str] = (),
                        inputs: Inputs | None = None) -> str:
    """Refuse, before any work, a folder that cannot be created or written (a file in the way, no permission, a
    dangling symbolic link, a name too long); ``files``, the names the command writes into it, are checked
    as :func:`check_output_path` does (a folder at the name, one of the command's ``inputs``)."""
    folder = os.fspath(folder)
    _check_shape(folder, what)
    if os.path.exists(folder) and not os.path.isdir(folder):
        raise ValueError(f"{what} {folder!r} is a file, not a folder")
    _check_folder(os.path.abspath(folder), what, folder)
    for name in files:
        check_output_path(os.path.join(folder, name), f"{what} file", inputs)
    return folder


def _check_folder(folder: str, what: str, given: str) -> None:
    probe = _nearest_existing(folder)
    if not os.path.isdir(probe):
        raise ValueError(f"{what} {given!r} cannot be created: {probe!r} is a file")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise ValueError(f"{what} {given!r} is not writable (no permission in {probe!r})")
    try:  # permission bits do not tell everything (root, a read-only mount, /proc): make and remove a folder there
        os.rmdir(tempfile.mkdtemp(prefix=".jaxdc-probe-", dir=probe))
    except OSError as e:
        raise ValueError(f"{what} {given!r} cannot be written: making a folder in {probe!r} failed "
                         f"({e.strerror or e})") from None


def enable_compilation_cache(path: str | None = None) -> None:
    """Turn on JAX's persistent compilation cache (default ``~/.cache/jaxdc/xla``).

    The command-line tools call this so that a second run skips most of the
    XLA compile time. Set ``JAXDC_NO_CACHE=1`` to turn it off.
    """
    if os.environ.get("JAXDC_NO_CACHE"):
        return
    import jax

    path = path or os.path.join(os.path.expanduser("~"), ".cache", "jaxdc", "xla")
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
