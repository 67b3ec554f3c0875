"""One run per folder: an exclusive lock on a run folder, held while a run uses it.

:func:`lock_folder` takes an ``fcntl.flock`` lock on ``FOLDER/.lock`` (the
file holds the holder's process id), so that a second run into the same
folder is refused at once, naming the folder and the process that holds it.
The kernel drops the lock when its process ends, however it ends (a SIGKILL
too), so a stale ``.lock`` file of a killed run blocks nothing; a run that
ends normally, with an error, with Ctrl-C or SIGTERM removes the file
(:meth:`FolderLock.release`, also run when the lock is garbage-collected or
at interpreter exit). Within one process the lock is shared: the run objects
of one folder (e.g. one built to restore a checkpoint while another trains
it) count their holds. POSIX only (``fcntl``), as the training runs.

The lock is taken on the folder's real path (symbolic links resolved: two names of one folder share one lock)
and covers what lies inside that folder only. So every folder a run writes into must resolve inside its run
folder: :func:`jaxdc.training.loop.check_run_folder` refuses, before the lock is taken, a ``checkpoints/`` (or
``tb/``) that is a symbolic link out of it, e.g. to another run's ``checkpoints/``, where a resume would delete
and rewrite the checkpoints of a run that another process may hold locked.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import weakref

from jaxdc.training.fields import SettingError

#: The lock file's name inside the run folder (a hidden file; no run artefact).
LOCK_NAME = ".lock"


class _Held:
    """This process's hold on one folder: the open lock file, how many :class:`FolderLock` share it, and whether
    the folder was created for the lock (then it is removed again if it is still empty at release)."""

    def __init__(self, fd: int, path: str, created: bool) -> None:
        self.fd, self.path, self.created, self.count = fd, path, created, 0


_HELD: dict[str, _Held] = {}  # real folder path -> this process's hold


class FolderLock:
    """A hold on a run folder's lock (:func:`lock_folder`); :meth:`release` it (idempotent) when the run ends."""

    def __init__(self, folder: str, real: str) -> None:
        self.folder = folder
        self._finalizer = weakref.finalize(self, _release, real)

    @property
    def held(self) -> bool:
        return self._finalizer.alive

    def release(self) -> None:
        """Give the hold back; the last one of the process unlocks and removes the lock file."""
        self._finalizer()


def lock_folder(folder: str) -> FolderLock:
    """Lock run folder ``folder`` (created if missing) for this process, or a :class:`SettingError` naming the
    folder and the process id of the run that holds it."""
    real = os.path.realpath(folder)
    held = _HELD.get(real)
    if held is None:
        created = not os.path.isdir(folder)
        os.makedirs(folder, exist_ok=True)
        path = os.path.join(folder, LOCK_NAME)
        fd = _open_locked(path, folder)
        if fd is None:
            if created:
                with contextlib.suppress(OSError):
                    os.rmdir(folder)
            raise SettingError(f"{{0}} {SettingError.text(folder)} is in use by another run "
                               f"({SettingError.text(_holder(path))}); wait for it to end, stop it, or choose another "
                               "{0}", "out")
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        held = _HELD[real] = _Held(fd, path, created)
    held.count += 1
    return FolderLock(folder, real)


def _open_locked(path: str, folder: str) -> int | None:
    """The descriptor of ``path`` locked by this process, or ``None`` if another process holds it."""
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as e:
            raise SettingError(f"{{0}} {SettingError.text(folder)}: cannot create its lock file "
                               f"({SettingError.text(e.strerror)})", "out") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return None
        # a holder that released meanwhile removed the file we opened: lock the current one instead
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)


def _holder(path: str) -> str:
    """Who holds the lock file ``path``, as its content says."""
    try:
        with open(path) as f:
            pid = f.read().strip()
    except OSError:
        pid = ""
    return f"process {pid}" if pid.isdigit() else "process id not yet written"


def _release(real: str) -> None:
    held = _HELD.get(real)
    if held is None:
        return
    held.count -= 1
    if held.count > 0:
        return
    del _HELD[real]
    with contextlib.suppress(OSError):
        os.unlink(held.path)  # while still locked, so that no other run sees a released file
    os.close(held.fd)
    if held.created:
        with contextlib.suppress(OSError):
            os.rmdir(os.path.dirname(held.path))  # only if still empty: a folder made just for the lock
