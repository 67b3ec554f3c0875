"""jaxdc.cli.main: the `jaxdc <group> <program>` command dispatches to each program."""

import subprocess
import sys

import pytest

from jaxdc.cli import main as jaxdc_main
from tests.support.cli_checks import ROOT


def test_help_lists_every_program(capsys):
    assert jaxdc_main.main(["--help"]) == 0
    out = capsys.readouterr().out
    for group, program in jaxdc_main.PROGRAMS:
        assert f"jaxdc {group} {program}" in out


def test_unknown_program_is_a_usage_error(capsys):
    assert jaxdc_main.main(["eval", "xyz"]) == 2
    assert "unknown program 'eval xyz'" in capsys.readouterr().err
    assert jaxdc_main.main([]) == 2


def test_dispatch_reaches_the_program(capsys):
    with pytest.raises(SystemExit) as e:
        jaxdc_main.main(["eval", "dcp", "--help"])
    assert e.value.code == 0 and "--table" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        jaxdc_main.main(["eval", "dcp", "--policy", "safe_reward", "--grid-size", "1"])
    assert e.value.code == 2 and "--grid-size" in capsys.readouterr().err


def test_a_program_runs_from_a_worker_thread():
    import threading

    from jaxdc.cli.runner import run

    out = {}
    t = threading.Thread(target=lambda: out.setdefault("rc", run(lambda argv: 7, "prog")))
    t.start()
    t.join()
    assert out["rc"] == 7


def test_a_long_evaluation_says_how_far_it_is(monkeypatch, capsys):
    # games that end only at a huge step cap: a command prints the progress of the loops it plays in its block
    import jax
    import numpy as np

    from jaxdc.cli import runner
    from jaxdc.core import grid, rollout
    from jaxdc.dcp.env import DCP

    monkeypatch.setattr(rollout, "HEARTBEAT_EVERY", 100)
    monkeypatch.setenv("JAXDC_PROGRESS_EVERY", "0")
    env = DCP(grid_size=4)

    def main(max_steps):
        params = env.make_params(np.zeros((4, 4)), (float("inf"), float("inf")), max_steps=max_steps)
        with runner.progress("prog", max_steps):
            jax.block_until_ready(jax.jit(lambda k: rollout.run_episodes(
                env, params, lambda k, o, s: jax.numpy.int32(grid.STAY), k, 3, lanes=2))(jax.random.PRNGKey(0)))
        return 0

    monkeypatch.setattr(runner, "LONG_GAME_STEPS", 400)
    assert runner.run(lambda argv: main(500), "prog") == 0
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("prog: evaluating: 0 of 3 episodes finished after 100 steps (")
    assert lines[-1].startswith("prog: evaluating: 2 of 3 episodes finished after 1,000 steps (")
    assert len(lines) == 10
    assert rollout._reporters == []  # the reporter ends with the block
    # a cap within LONG_GAME_STEPS compiles no progress call and prints nothing
    assert runner.run(lambda argv: main(400), "prog") == 0
    assert capsys.readouterr().err == ""
    # the default interval prints nothing in a short run; a bad interval is refused by name
    monkeypatch.delenv("JAXDC_PROGRESS_EVERY")
    assert runner.run(lambda argv: main(500), "prog") == 0
    assert capsys.readouterr().err == ""
    for bad in ("soon", "-1", "inf", "nan"):
        monkeypatch.setenv("JAXDC_PROGRESS_EVERY", bad)
        assert runner.run(lambda argv: main(500), "prog") == 2
        assert f"JAXDC_PROGRESS_EVERY must be a finite number of seconds >= 0, got {bad!r}" in capsys.readouterr().err


def test_progress_lines_come_at_most_every_interval():
    import io

    from jaxdc.cli.runner import progress_printer

    now = [0.0]
    out = io.StringIO()
    report = progress_printer("prog", 60.0, out, clock=lambda: now[0])
    for t, finished in ((30, 1), (61, 2), (90, 3), (121, 4), (300, 5)):
        now[0] = float(t)
        report(finished, 10_000, t * 1000)
    assert out.getvalue().splitlines() == [
        "prog: evaluating: 2 of 10,000 episodes finished after 61,000 steps (1.0 min)",
        "prog: evaluating: 4 of 10,000 episodes finished after 121,000 steps (2.0 min)",
        "prog: evaluating: 5 of 10,000 episodes finished after 300,000 steps (5.0 min)",
    ]


@pytest.mark.parametrize(("sig", "status", "word"), [("SIGTERM", 143, "terminated"), ("SIGINT", 130, "interrupted")])
def test_a_signal_during_a_long_compiled_call_ends_the_process_after_the_grace(sig, status, word):
    """Python runs a handler only between bytecodes, so a signal that comes inside one long XLA call would wait
    for it (minutes); the entry point's watchdog ends the process ``JAXDC_INTERRUPT_GRACE`` seconds after it."""
    import signal
    import time

    from tests.support.cli_checks import checkout_env, cli_process

    with cli_process(["tests.support.spin"], env={**checkout_env(), "JAXDC_INTERRUPT_GRACE": "1"},
                     stdout=subprocess.PIPE) as proc:
        assert proc.stdout.readline().strip() == "ready", proc.stderr
        time.sleep(0.5)  # inside the long call now
        sent = time.monotonic()
        proc.send_signal(getattr(signal, sig))
        _, err = proc.communicate(timeout=60)
        took = time.monotonic() - sent
    assert proc.returncode == status, err
    assert err.strip().splitlines() == [f"spin: {word} (by the watchdog, 1 s after the signal: a compiled call was "
                                        "still running)"], err
    assert 1.0 <= took < 30.0, took  # the loop itself runs for minutes


def test_a_bad_interrupt_grace_is_a_usage_error_naming_it():
    from tests.support.cli_checks import checkout_env

    env = {**checkout_env(), "JAXDC_INTERRUPT_GRACE": "soon"}
    done = subprocess.run([sys.executable, "-m", "eval.dcp", "--help"], env=env, capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert done.returncode == 2, done
    assert done.stderr.strip() == ("python -m eval.dcp: error: JAXDC_INTERRUPT_GRACE must be a finite number of "
                                   "seconds >= 0, got 'soon'")


def test_the_watchdog_stops_and_gives_the_wakeup_descriptor_back():
    """``stop_after_signal``'s stop function restores the previous wakeup descriptor and ends the thread."""
    import signal
    import threading
    import time

    from jaxdc.cli.runner import stop_after_signal

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal.set_wakeup_fd needs the main thread")
    before = signal.set_wakeup_fd(-1)
    signal.set_wakeup_fd(before)
    stop = stop_after_signal("prog", 60.0)
    ours = signal.set_wakeup_fd(-1)
    signal.set_wakeup_fd(ours, warn_on_full_buffer=False)
    assert ours not in (-1, before)  # the watchdog's pipe, while it runs
    stop()
    assert signal.set_wakeup_fd(before) == before
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and any(t.name == "jaxdc-signal-watchdog" for t in threading.enumerate()):
        time.sleep(0.05)
    assert not any(t.name == "jaxdc-signal-watchdog" for t in threading.enumerate())
