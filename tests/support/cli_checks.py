"""Checks shared by the command-line tests: a refused command line, a tiny finished training run and its restored
state, the settings a training command line settles on, the checkout's subprocesses (``python -m train.*`` from the
repository root)."""

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from typing import Iterator

#: The repository root: the checkout whose ``train/`` and ``eval/`` shims the subprocess tests start.
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))



def strict_json(text: str):
    """Parse JSON refusing NaN and Infinity (what every jaxdc output must be)."""
    def refuse(c):
        raise AssertionError(f"non-strict JSON constant {c}")
    return json.loads(text, parse_constant=refuse)


def checkout_env() -> dict:
    """The environment of a subprocess of the checkout: :data:`ROOT` first on ``PYTHONPATH``."""
    return dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))


def wait_for(predicate, timeout: float) -> bool:
    """Whether ``predicate()`` turned true within ``timeout`` seconds (polled every 0.1 s)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if predicate():
            return True
        time.sleep(0.1)
    return False


@contextlib.contextmanager
def cli_process(argv: list, env: dict | None = None, stdout=subprocess.PIPE) -> Iterator[subprocess.Popen]:
    """``python -m *argv`` started from :data:`ROOT` in a process group of its own (``env``: default
    :func:`checkout_env`; stderr piped, text). Whatever the test does -- passes, fails an assertion, times out in
    ``communicate`` -- the group is killed (SIGKILL) on leaving the block, so no CLI, nor any child it started,
    outlives the test. A signal the test sends with ``proc.send_signal`` reaches the CLI's own process alone (passing it
    on to its children is the CLI's job, which the Ctrl-C tests check)."""
    proc = subprocess.Popen([sys.executable, "-m", *argv], cwd=ROOT, env=checkout_env() if env is None else env,
                            start_new_session=True, stdout=stdout, stderr=subprocess.PIPE, text=True)
    try:
        yield proc
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()  # reaps it and closes the pipes


def refused(main, argv, capsys, *needles, code=2) -> str:
    """``main(argv)`` exits ``code`` (argparse's SystemExit or a returned status) with an error naming every one
    of ``needles`` (case-insensitive), no traceback and nothing on stdout; the error text."""
    try:
        rc = main(argv)
    except SystemExit as e:
        rc = e.code
    got = capsys.readouterr()
    assert rc == code, got
    assert "Traceback" not in got.err
    for n in needles:
        assert n.lower() in got.err.lower(), (n, got.err)
    assert got.out == ""
    return got.err


def refused_leaving_no_run(main, argv, out, capsys, *needles) -> str:
    """:func:`refused` for ``argv`` with ``--out out``, and no run folder ``out`` made; the error text."""
    err = refused(main, [*argv, "--out", str(out)], capsys, *needles)
    assert not os.path.exists(out)
    return err


def tiny_run(main, argv, tmp_path_factory) -> str:
    """The folder of a training run ``main(argv + ["--out", folder])`` that finished (exit 0)."""
    out = str(tmp_path_factory.mktemp("runs") / "tiny")
    assert main(argv + ["--out", out]) == 0
    return out


def resumes_exactly(main, argv, finished: str, tmp_path, last_step: int, restore) -> str:
    """A copy of the ``finished`` run without its last checkpoint (as if killed after the one before) resumed
    with ``--resume`` ends with the same training state (``restore(folder)``); the resumed folder."""
    import os
    import shutil

    import jax
    import numpy as np

    out = str(tmp_path / "killed")
    shutil.copytree(finished, out)
    shutil.rmtree(os.path.join(out, "checkpoints", str(last_step)))
    assert main(argv + ["--out", out, "--resume"]) == 0
    a, b = restore(finished), restore(out)
    assert int(a.update) == int(b.update) == last_step
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    return out


def settle(cli, problem: str, argv: list):
    """The settings that ``cli`` (:mod:`jaxdc.cli.train_dcp` or :mod:`jaxdc.cli.train_dcg`) settles on for
    ``argv``, a ``--config`` read as the command reads it."""
    from jaxdc.cli.train_common import parse_with_config
    from jaxdc.training import dcg, dcp

    from_metadata = {"dcg": dcg, "dcp": dcp}[problem].settings_from_metadata
    return cli.settle(parse_with_config(cli.build_parser(), argv, problem, from_metadata))


def restore_run(cli, argv: list, out: str):
    """The training state stored in the run folder ``out`` of the command line ``argv``, as ``cli`` restores it."""
    import jax

    from jaxdc import checkpoint

    run = cli.Run(cli.build_parser().parse_args(argv + ["--out", out]))
    state, _ = checkpoint.restore(run.ckpt_dir, run.trainer.init(jax.random.PRNGKey(0)), run.metadata)
    return state
