"""jaxdc.cli.main: the `jaxdc <group> <program>` command dispatches to each program."""

import pytest

from jaxdc.cli import main as jaxdc_main


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
    # games that end only at a large step cap: every command line prints the progress of its evaluation loops
    import jax
    import numpy as np

    from jaxdc.cli.runner import run
    from jaxdc.core import grid, rollout
    from jaxdc.dcp.env import DCP

    monkeypatch.setattr(rollout, "HEARTBEAT_EVERY", 100)
    monkeypatch.setenv("JAXDC_PROGRESS_EVERY", "0")
    env = DCP(grid_size=4)
    params = env.make_params(np.zeros((4, 4)), (float("inf"), float("inf")), max_steps=500)

    def main(argv):
        jax.block_until_ready(rollout.run_episodes(env, params, lambda k, o, s: jax.numpy.int32(grid.STAY),
                                                   jax.random.PRNGKey(0), 3, lanes=2))
        return 0

    assert run(main, "prog") == 0
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("prog: evaluating: 0 of 3 episodes finished after 100 steps (")
    assert lines[-1].startswith("prog: evaluating: 2 of 3 episodes finished after 1,000 steps (")
    assert len(lines) == 10
    assert rollout._reporters == []  # the reporter ends with the program
    # the default prints nothing in a short run; a bad interval is refused by name
    monkeypatch.delenv("JAXDC_PROGRESS_EVERY")
    assert run(main, "prog") == 0
    assert capsys.readouterr().err == ""
    for bad in ("soon", "-1", "inf", "nan"):
        monkeypatch.setenv("JAXDC_PROGRESS_EVERY", bad)
        assert run(main, "prog") == 2
        assert f"JAXDC_PROGRESS_EVERY must be a finite number of seconds >= 0, got {bad!r}" in capsys.readouterr().err
