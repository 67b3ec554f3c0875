"""Several processes (jaxdc.training.distributed): the cluster settings, and two local processes that train as one.

Two ``train.dcp`` processes joined through ``--coordinator 127.0.0.1:PORT`` (a
port free at run time; gloo CPU collectives, which the command selects itself)
form one 2-device mesh. They must end with exactly the training state of one
process over two forced host devices (``--xla_force_host_platform_device_count=2``):
it is the same partitioned program on the same two-device mesh, each device
steps the same half of the environments, and the one cross-device reduction
(the gradient mean's all-reduce) adds two numbers, which is exact whatever the
order, so the test asks for bit-identical states, not a tolerance. Process 1 is
given its own ``--out`` and must not create it (only process 0 writes); the
2-process run without its last checkpoint, resumed by two processes again,
ends where it ended. The three first processes run side by side (mostly
single-threaded XLA compilation); the resumed run loads their compiles from the
session's XLA cache.
"""

from __future__ import annotations

import csv
import os
import shutil
import socket
import subprocess
import sys

import numpy as np
import pytest

from jaxdc.training.distributed import Cluster, parse_address
from jaxdc.training.fields import SettingError
from tests.support.cli_checks import ROOT, checkout_env

# 6 updates of 4 environments x 2 steps; a checkpoint every 2 updates (steps 2, 4, 6)
TINY = ["--net", "linear", "--grid-size", "4", "--total-reward", "5", "--max-steps", "30", "--envs", "4",
        "--t-max", "2", "--steps", "48", "--eval-every", "16", "--eval-episodes", "4", "--no-progress"]
LAST = 6
TIMEOUT_S = 300


# ------------------------------------------------------------------------------------------ settings
def test_no_fields_is_one_process():
    assert not Cluster().active


@pytest.mark.parametrize("text, want", [("127.0.0.1:1234", ("127.0.0.1", 1234)), ("node-7:65535", ("node-7", 65535)),
                                        ("[::1]:1", ("[::1]", 1))])
def test_address_parses(text, want):
    assert parse_address(text) == want


@pytest.mark.parametrize("text", ["127.0.0.1", ":1234", "host:0", "host:65536", "host:-1", "host:12a", ""])
def test_bad_address_is_named(text):
    with pytest.raises(ValueError, match="HOST:PORT"):
        parse_address(text)


@pytest.mark.parametrize("kwargs, needles", [
    (dict(coordinator="h:1", num_processes=2), ["process_id", "missing"]),
    (dict(process_id=0), ["coordinator", "num_processes", "missing"]),
    (dict(coordinator="h:1", num_processes=2, process_id=2), ["process_id", "[0, 2)", "2"]),
    (dict(coordinator="h:1", num_processes=2, process_id=-1), ["process_id", "-1"]),
    (dict(coordinator="h:1", num_processes=0, process_id=0), ["num_processes", "0"]),
    (dict(coordinator="h:99999", num_processes=2, process_id=0), ["coordinator", "99999"]),
    (dict(auto_cluster=True, process_id=0), ["auto_cluster", "process_id"]),
])
def test_bad_cluster_names_the_field_and_value(kwargs, needles):
    with pytest.raises(SettingError) as e:
        Cluster(**kwargs)
    for n in needles:
        assert n in str(e.value), (n, str(e.value))


def test_explicit_and_auto_are_active():
    assert Cluster(coordinator="h:1", num_processes=1, process_id=0).active
    assert Cluster(auto_cluster=True).active


# ------------------------------------------------------------------------------------------ two processes
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(argv: list[str], log: str, **env: str) -> subprocess.Popen:
    with open(log, "w") as f:
        return subprocess.Popen([sys.executable, "-m", "train.dcp", *TINY, *argv], cwd=ROOT, stdout=f,
                                stderr=subprocess.STDOUT, env=dict(checkout_env(), **env))


def _finish(procs: list[subprocess.Popen], logs: list[str]) -> None:
    """Wait for all; on a failure or a hang stop the others and show the logs."""
    try:
        codes = [p.wait(timeout=TIMEOUT_S) for p in procs]
    except subprocess.TimeoutExpired:
        codes = None
    for p in procs:
        if p.poll() is None:
            p.kill()
            p.wait()
    if codes != [0] * len(procs):
        text = "\n".join(f"--- {log}\n" + open(log).read()[-3000:] for log in logs)
        pytest.fail(f"exit statuses {codes}\n{text}")


def _two_processes(tmp_path, name: str, outs: tuple[str, str], extra: tuple[str, ...] = ()) -> list[str]:
    port = _free_port()
    logs = [str(tmp_path / f"{name}-{i}.log") for i in range(2)]
    return logs, [_start(["--out", outs[i], "--coordinator", f"127.0.0.1:{port}", "--num-processes", "2",
                          "--process-id", str(i), *extra], logs[i]) for i in range(2)]


def _state(folder: str, step: int) -> dict:
    """The stored training state of checkpoint ``step``, as flat ``{path: array}``."""
    import jax
    import orbax.checkpoint as ocp

    with ocp.CheckpointManager(os.path.abspath(os.path.join(folder, "checkpoints"))) as m:
        tree = m.restore(step, args=ocp.args.Composite(state=ocp.args.StandardRestore())).state
    return {jax.tree_util.keystr(k): np.asarray(v) for k, v in jax.tree_util.tree_leaves_with_path(tree)}


def _assert_same_state(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def _evaluations(folder: str) -> list[dict]:
    with open(os.path.join(folder, "metrics.csv")) as f:
        return [{k: v for k, v in row.items() if k not in ("wall_s", "steps_per_s")} for row in csv.DictReader(f)]


@pytest.mark.slow  # five CLI processes; about 6 minutes on the busy 2-core machine it was written on (load 12)
def test_two_processes_train_as_one_process_over_two_devices_and_resume(tmp_path):
    multi, single, silent = (str(tmp_path / n) for n in ("multi", "single", "process1"))
    logs, procs = _two_processes(tmp_path, "multi", (multi, silent))
    logs.append(str(tmp_path / "single.log"))
    procs.append(_start(["--out", single], logs[-1], XLA_FLAGS="--xla_force_host_platform_device_count=2"))
    _finish(procs, logs)

    assert not os.path.exists(silent), os.listdir(silent)  # process 1 wrote nothing
    assert sorted(os.listdir(os.path.join(multi, "checkpoints"))) == ["2", "4", "6"]
    _assert_same_state(_state(multi, LAST), _state(single, LAST))
    assert _evaluations(multi) == _evaluations(single)
    assert len(_evaluations(multi)) == 3
    assert "done: seed 0, 48 steps" in open(logs[0]).read()
    assert "done:" not in open(logs[1]).read()  # the others neither evaluate nor report

    killed = str(tmp_path / "killed")
    shutil.copytree(multi, killed)
    shutil.rmtree(os.path.join(killed, "checkpoints", str(LAST)))
    logs, procs = _two_processes(tmp_path, "resume", (killed, killed), ("--resume",))
    _finish(procs, logs)
    _assert_same_state(_state(killed, LAST), _state(multi, LAST))
    assert _evaluations(killed) == _evaluations(multi)
