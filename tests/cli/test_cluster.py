"""The several-processes flags of train.dcp / train.dcg (jaxdc.cli.cluster): each bad value or combination is a
usage error naming the flag and the value, before any JAX work; the two-process runs themselves are in
tests/training/test_distributed.py."""

from __future__ import annotations

import argparse

import pytest

from jaxdc.cli import train_dcg, train_dcp
from jaxdc.cli.cluster import cluster, coordinator
from tests.support.cli_checks import refused


@pytest.mark.parametrize("extra, needles", [
    (["--coordinator", "127.0.0.1:70000", "--num-processes", "2", "--process-id", "0"],
     ["--coordinator", "70000", "[1, 65535]"]),
    (["--coordinator", "127.0.0.1", "--num-processes", "2", "--process-id", "0"], ["--coordinator", "HOST:PORT"]),
    (["--coordinator", "127.0.0.1:1234", "--num-processes", "2"], ["--process-id", "missing"]),
    (["--process-id", "1"], ["--coordinator", "--num-processes", "missing"]),
    (["--coordinator", "127.0.0.1:1234", "--num-processes", "2", "--process-id", "2"], ["--process-id", "[0, 2)"]),
    (["--coordinator", "127.0.0.1:1234", "--num-processes", "0", "--process-id", "0"], ["--num-processes", "0"]),
    (["--coordinator", "127.0.0.1:1234", "--num-processes", "2", "--process-id", "-1"], ["--process-id", "-1"]),
    (["--auto-cluster", "--process-id", "0"], ["--auto-cluster", "--process-id"]),
])
def test_bad_cluster_flags_are_usage_errors(extra, needles, capsys, tmp_path):
    refused(train_dcp.main, ["--out", str(tmp_path / "run"), *extra], capsys, *needles)
    assert not (tmp_path / "run").exists()


def test_train_dcg_takes_the_same_flags(capsys, tmp_path):
    refused(train_dcg.main, ["--out", str(tmp_path / "run"), "--coordinator", "h:1", "--num-processes", "3",
                             "--process-id", "3"], capsys, "--process-id", "[0, 3)")


def test_flags_settle_into_a_cluster():
    args = train_dcp.build_parser().parse_args(["--coordinator", "node0:1234", "--num-processes", "4",
                                                "--process-id", "3"])
    c = cluster(args)
    assert (c.coordinator, c.num_processes, c.process_id, c.auto_cluster, c.active) == ("node0:1234", 4, 3, False,
                                                                                       True)
    assert not cluster(train_dcp.build_parser().parse_args([])).active
    assert cluster(train_dcp.build_parser().parse_args(["--auto-cluster"])).active


def test_coordinator_type_names_the_value():
    assert coordinator("[::1]:99") == "[::1]:99"
    with pytest.raises(argparse.ArgumentTypeError, match="'x:0'"):
        coordinator("x:0")
