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
