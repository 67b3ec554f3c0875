"""Hostile input for benchmarks/env_throughput.py: counts, the output folder, memory.

Every bad value is refused before any work with a non-zero exit and one line naming the flag (or the file and
key), the value and the allowed range, without a traceback; no NaN or Infinity reaches a file or stdout; an
interruption leaves the old files or the complete new set.
"""

from __future__ import annotations

import pytest

from benchmarks import env_throughput
from tests.support.cli_checks import refused

_refused = refused


# ----------------------------------------------------------------------------- benchmarks/env_throughput.py


@pytest.mark.parametrize("argv, flag", [
    (["--numpy-steps", "0"], "--numpy-steps"), (["--episodes", "0"], "--episodes"), (["--repeats", "0"], "--repeats"),
    (["--steps", "0"], "--steps"), (["--batch-sizes", "4", "0"], "--batch-sizes"),
    (["--repeats", "3000000000"], "--repeats"),
])
def test_benchmark_count_flag_refused(tmp_path, capsys, argv, flag):
    _refused(env_throughput.main, argv + ["--quick", "--out-dir", str(tmp_path / "o")], capsys, flag)
    assert not (tmp_path / "o").exists()


def test_benchmark_out_dir_checked_first(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    _refused(env_throughput.main, ["--quick", "--out-dir", str(tmp_path / "f")], capsys, "--out-dir", "not a folder")


def test_benchmark_batch_too_large_for_memory(tmp_path, monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**30))
    with pytest.raises(MemoryError, match="--batch-sizes"):
        env_throughput.main(["--quick", "--batch-sizes", "2000000000", "--out-dir", str(tmp_path / "o")])
    assert not (tmp_path / "o").exists()
