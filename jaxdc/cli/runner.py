"""How every jaxdc command line ends: exit statuses, one-line errors, Ctrl-C.

:func:`run` calls a program's ``main(argv)`` and turns

* ``KeyboardInterrupt`` (Ctrl-C, SIGINT) into exit status 130 with one line
  on stderr (files are written atomically, so the old or the complete new set
  is left);
* SIGTERM into the same path as Ctrl-C (status 143);
* a ``ValueError``/``TypeError`` raised by jaxdc's validation, or the
  ``MemoryError`` of a request too big for the machine (:mod:`jaxdc.core.memory`),
  into ``<prog>: error: <message>`` and exit status 2, as argparse does for flags.

Set ``JAXDC_DEBUG=1`` to see the full traceback instead.

:func:`progress` is how a command whose step cap allows long games (a huge
``--max-steps``, games that never end) says how far its evaluation is: one
line on stderr at most every ``JAXDC_PROGRESS_EVERY`` seconds (default 60;
:func:`progress_printer`, fed by :func:`jaxdc.core.rollout.reporting`).

:func:`exit_process` ends a command-line process with a status: after an
interruption it flushes and leaves with ``os._exit``, because the interpreter's
normal shutdown can crash while JAX's runtime threads are still busy.

Python runs a signal's handler only between two bytecodes of the main thread, so
a Ctrl-C or SIGTERM that arrives during one long compiled call (a batched
evaluation of millions of steps) would wait for the call to return, minutes
later. :func:`entry` therefore starts a watchdog (:func:`stop_after_signal`):
if the main thread has not ended the process ``JAXDC_INTERRUPT_GRACE`` seconds
(default :data:`INTERRUPT_GRACE`) after the signal, the watchdog ends it with
the same status and line. Nothing is left half-written: every result file is
written atomically and a training run resumes from its last checkpoint, as
after a SIGKILL.

:func:`command_line` is the one way a program records its own command line
(in its results files and metadata); :func:`with_subcommand` gives a program
with subcommands its default one when a command line names none.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import ContextManager, TextIO

#: Exit statuses: a usage or input error (as argparse), Ctrl-C, SIGTERM.
EXIT_USAGE, EXIT_INTERRUPTED, EXIT_TERMINATED = 2, 130, 143
#: Seconds between two progress lines of a long evaluation, unless ``JAXDC_PROGRESS_EVERY`` says otherwise.
PROGRESS_EVERY = 60.0
#: A step cap above this allows games long enough to want progress lines (the defaults are 100 and 1,000).
LONG_GAME_STEPS = 100_000
#: Seconds the main thread gets to end the process after Ctrl-C or SIGTERM before the watchdog of :func:`entry`
#: ends it (``JAXDC_INTERRUPT_GRACE`` overrides).
INTERRUPT_GRACE = 5.0


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that the same clean-up runs as for Ctrl-C."""


def _on_sigterm(signum, frame):
    raise Terminated()


def command_line(prog: str, argv: Sequence[str] | None = None) -> str:
    """The command line a results file records: ``prog`` (as is, e.g. ``"python -m eval.dcp"``), one space, then
    ``argv`` (default ``sys.argv[1:]``) quoted by ``shlex.join``, so that it can be pasted back into a shell.

    >>> command_line("python -m eval.dcp", ["--table", "4.3"])
    'python -m eval.dcp --table 4.3'
    """
    return f"{prog} {shlex.join(sys.argv[1:] if argv is None else list(argv))}"


def with_subcommand(argv: Sequence[str] | None, subcommands: Sequence[str], default: str) -> list[str]:
    """``argv`` (default ``sys.argv[1:]``) as the parser of a program with subcommands reads it: unchanged when it
    starts with one of ``subcommands``, else with ``default`` put in front (``-h`` too: the default subcommand's
    help), so that a command line without a subcommand keeps meaning what it meant before."""
    argv = list(sys.argv[1:] if argv is None else argv)
    return argv if argv and argv[0] in subcommands else [default, *argv]


def _seconds_from_env(name: str, default: float) -> float:
    """The environment variable ``name`` as seconds (a finite number >= 0), or ``default`` when it is unset or
    empty; anything else is a ``ValueError`` naming the variable and the value."""
    raw = os.environ.get(name)
    if raw is None or raw == "":
        return default
    try:
        seconds = float(raw)
    except ValueError:
        seconds = float("nan")
    if not seconds >= 0.0 or seconds == float("inf"):
        raise ValueError(f"{name} must be a finite number of seconds >= 0, got {raw!r}")
    return seconds


def progress_every() -> float:
    """``JAXDC_PROGRESS_EVERY`` (seconds, a finite number >= 0) or :data:`PROGRESS_EVERY`; refused by name."""
    return _seconds_from_env("JAXDC_PROGRESS_EVERY", PROGRESS_EVERY)


def interrupt_grace() -> float:
    """``JAXDC_INTERRUPT_GRACE`` (seconds, a finite number >= 0) or :data:`INTERRUPT_GRACE`; refused by name."""
    return _seconds_from_env("JAXDC_INTERRUPT_GRACE", INTERRUPT_GRACE)


def stop_after_signal(prog: str, grace: float) -> Callable[[], None]:
    """Start the watchdog of an entry point; the function that stops it again.

    The C-level signal handler writes each signal it catches into a pipe (``signal.set_wakeup_fd``) at once, even
    while the main thread is inside a compiled call. A daemon thread reads the pipe; ``grace`` seconds after a
    Ctrl-C or SIGTERM it writes ``<prog>: interrupted`` / ``terminated`` and ends the process with
    :data:`EXIT_INTERRUPTED` / :data:`EXIT_TERMINATED` -- unless the main thread's own handling (:func:`run`,
    :func:`exit_process`) has ended it first, as it does whenever it is running Python. Only the main thread can
    own the wakeup descriptor; elsewhere nothing is started.
    """
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)
    previous = signal.set_wakeup_fd(write_end, warn_on_full_buffer=False)

    def watch() -> None:
        while True:
            caught = os.read(read_end, 64)
            if not caught:  # stop() closed the write end
                os.close(read_end)
                return
            if signal.SIGTERM in caught or signal.SIGINT in caught:
                time.sleep(grace)
                terminated = signal.SIGTERM in caught
                print(f"{prog}: {'terminated' if terminated else 'interrupted'} (by the watchdog, {grace:g} s "
                      "after the signal: a compiled call was still running)", file=sys.stderr, flush=True)
                sys.stdout.flush()
                os._exit(EXIT_TERMINATED if terminated else EXIT_INTERRUPTED)

    threading.Thread(target=watch, name="jaxdc-signal-watchdog", daemon=True).start()

    def stop() -> None:  # the reader sees the end of the pipe and closes its side
        signal.set_wakeup_fd(previous)
        os.close(write_end)

    return stop


def progress_printer(prog: str, every: float, stream: TextIO | None = None,
                     clock: Callable[[], float] = time.monotonic) -> Callable[[int, int, int], None]:
    """A reporter for :func:`jaxdc.core.rollout.reporting`: ``report(finished, total, steps)`` writes one line
    to ``stream`` (default stderr) when ``every`` seconds have passed since the last line (or since this call)."""
    start = last = clock()

    def report(finished: int, total: int, steps: int) -> None:
        nonlocal last
        now = clock()
        if now - last < every:
            return
        last = now
        print(f"{prog}: evaluating: {finished:,} of {total:,} episodes finished after {steps:,} steps "
              f"({(now - start) / 60:.1f} min)", file=stream or sys.stderr, flush=True)

    return report


def progress(prog: str, max_steps: int | None) -> ContextManager[None]:
    """The block a command evaluates in: with a step cap over :data:`LONG_GAME_STEPS`, the evaluation loops
    traced inside it print their progress (:func:`progress_printer`); otherwise nothing changes, and the
    loops stay cacheable by JAX's persistent compile cache (which skips programs with host callbacks)."""
    if max_steps is None or max_steps <= LONG_GAME_STEPS:
        return contextlib.nullcontext()
    from jaxdc.core import rollout

    return rollout.reporting(progress_printer(prog, progress_every()))


def run(main, prog: str, argv=None) -> int:
    """``main(argv)``'s exit status, with the conventions above."""
    debug = bool(os.environ.get("JAXDC_DEBUG"))
    # signal handlers can only be set from the main thread; elsewhere SIGTERM keeps its handler
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _on_sigterm) if main_thread else None
    try:
        return int(main(argv) or 0)
    except Terminated:
        print(f"{prog}: terminated", file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (ValueError, TypeError, MemoryError) as e:
        if debug:
            raise
        print(f"{prog}: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, previous)


def exit_process(status: int):
    """End the process with ``status`` (the entry points' last call; never from a library or a test)."""
    if status in (EXIT_INTERRUPTED, EXIT_TERMINATED):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    sys.exit(status)


def guard_process(prog: str, status: Callable[[], int]) -> None:
    """End the process with ``status()``, run under the watchdog of :func:`stop_after_signal` (``grace`` from
    ``JAXDC_INTERRUPT_GRACE``, refused by name as a usage error): how an entry point or the console script ends."""
    try:
        grace = interrupt_grace()
    except ValueError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        exit_process(EXIT_USAGE)
    stop_after_signal(prog, grace)  # for the life of the process: it ends in exit_process
    exit_process(status())


def entry(module: str, prog: str) -> None:
    """A ``python -m`` entry point: import ``module`` and run its ``main`` under :func:`run`, then exit.

    The import is inside the interruption handling too, so a Ctrl-C while the libraries load also
    exits 130 with one line; the watchdog of :func:`stop_after_signal` ends the process if the main thread is
    inside a long compiled call when the signal comes.
    """
    import importlib

    guard_process(prog, lambda: run(lambda argv: importlib.import_module(module).main(argv), prog))
