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


def progress_every() -> float:
    """``JAXDC_PROGRESS_EVERY`` (seconds, a finite number >= 0) or :data:`PROGRESS_EVERY`; refused by name."""
    raw = os.environ.get("JAXDC_PROGRESS_EVERY")
    if raw is None or raw == "":
        return PROGRESS_EVERY
    try:
        every = float(raw)
    except ValueError:
        every = float("nan")
    if not every >= 0.0 or every == float("inf"):
        raise ValueError(f"JAXDC_PROGRESS_EVERY must be a finite number of seconds >= 0, got {raw!r}")
    return every


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


def entry(module: str, prog: str) -> None:
    """A ``python -m`` entry point: import ``module`` and run its ``main`` under :func:`run`, then exit.

    The import is inside the interruption handling too, so a Ctrl-C while the libraries load also
    exits 130 with one line.
    """
    import importlib

    exit_process(run(lambda argv: importlib.import_module(module).main(argv), prog))
