"""jaxdc.drp.analysis.parallel after faults: a SIGKILL of the parent leaves no worker alive (issue 31)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

from tests.support.cli_checks import ROOT

PARENT = """
import multiprocessing as mp, os, sys, time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.managers import SyncManager
from jaxdc.drp.analysis.parallel import die_with_parent

if __name__ == "__main__":
    ctx = mp.get_context("spawn")
    manager = SyncManager(ctx=ctx)
    manager.start(die_with_parent, (os.getpid(),))
    pool = ProcessPoolExecutor(2, mp_context=ctx, initializer=die_with_parent, initargs=(os.getpid(),))
    futures = [pool.submit(time.sleep, 120) for _ in range(2)]
    deadline = time.time() + 60
    while len(mp.active_children()) < 3 and time.time() < deadline:  # the workers start when a job is sent
        time.sleep(0.1)
    time.sleep(1.0)  # their initializer has run once the jobs are under way
    pids = [p.pid for p in mp.active_children()]
    print(" ".join(map(str, pids)), flush=True)
    time.sleep(120)
"""


def _alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


def test_workers_and_manager_die_when_the_parent_is_killed():
    env = {**os.environ, "PYTHONPATH": ROOT}
    parent = subprocess.Popen([sys.executable, "-c", PARENT], stdout=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    try:
        deadline = time.time() + 60
        pids = []
        while len(pids) < 3 and time.time() < deadline:  # the manager and two workers
            line = parent.stdout.readline()
            pids = [int(p) for p in line.split()] if line.strip() else pids
            if not line:
                break
        assert len(pids) >= 3, pids
        assert all(_alive(p) for p in pids)
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=10)
        deadline = time.time() + 5
        while any(_alive(p) for p in pids) and time.time() < deadline:
            time.sleep(0.1)
        assert not any(_alive(p) for p in pids), [p for p in pids if _alive(p)]
    finally:
        if parent.poll() is None:
            parent.kill()
