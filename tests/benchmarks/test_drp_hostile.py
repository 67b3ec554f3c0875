"""Hostile input for benchmarks.drp: bad flags are refused, not defaulted.
"""


import pytest

# ----------------------------------------------------------------------------- benchmark


@pytest.mark.parametrize("argv, needle", [(["--nodes", "0"], "--nodes"), (["--alpha", "nan"], "--alpha"),
                                          (["--fig-alphas", "nan,1"], "--fig-alphas"),
                                          (["--fig-graphs", "0"], "--fig-graphs"),
                                          (["--cc-builders", "xx"], "--cc-builders"),
                                          (["--cc-rounds", "cached,bogus"], "--cc-rounds"),
                                          (["--build-sizes", "4x0"], "--build-sizes"),
                                          (["--cc-graphs", "99999999999999999999"], "--cc-graphs")])
def test_benchmark_flags_are_refused_not_defaulted(capsys, argv, needle):
    from benchmarks import drp as bench

    with pytest.raises(SystemExit) as e:
        bench.main(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2 and needle in err and "Traceback" not in err
