"""The section 3.5 experiment split over processes, each taking a group of builders.

Each worker process runs NC with its builders and the PGC plans with them, and
compiles only their programs; the parent computes the PGC clusters (pure
Python) meanwhile and sends them to every worker. The rewards are computed
from the tours on the host (float64), so the results equal
:func:`jaxdc.drp.analysis.experiment.run_experiment`'s in one process.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time

from jaxdc.drp.analysis.experiment import experiment_arrays, pgc_plans, progress_units, run_experiment
from jaxdc.drp.solve import pgc_clusters
from jaxdc.io import enable_compilation_cache

#: Relative cost of NC with each builder (NC + GI = 1), from the per-part times of the full figure-3.1 run
#: (100 graphs x 100 nodes, docs/drp.md); only used to balance the processes.
NC_COST = {"gi": 1.0, "gml": 0.50, "osa": 0.34, "lpg": 0.24, "tl": 0.24, "ng": 0.17}


def builder_groups(builders, workers):
    """Split ``builders`` over at most ``workers`` processes, heaviest first onto the lightest process."""
    groups = [[] for _ in range(min(workers, len(builders)))]
    load = [0.0] * len(groups)
    for b in sorted(builders, key=lambda b: -NC_COST.get(b, 1.0)):
        i = load.index(min(load))
        groups[i].append(b)
        load[i] += NC_COST.get(b, 1.0)
    return groups


@contextlib.contextmanager
def _children_ignore_ctrl_c():
    """Start worker processes that never see a Ctrl-C sent to the whole process group.

    While the block runs, SIGINT is ignored (a disposition that survives ``exec``, so the spawned
    interpreters start with it ignored and keep it) and blocked in this thread (so that a Ctrl-C
    arriving meanwhile stays pending instead of being lost). On exit the handler is restored first,
    then the mask, so the parent still receives a pending Ctrl-C and stops the children."""
    main = threading.current_thread() is threading.main_thread()
    can_mask = hasattr(signal, "pthread_sigmask") and os.name == "posix"
    old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT}) if can_mask else None
    old_handler = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        yield
    finally:
        if main:
            signal.signal(signal.SIGINT, old_handler)
        if can_mask:
            signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)


def die_with_parent(parent: int) -> None:
    """Make this (worker) process end when the process ``parent`` dies, even by SIGKILL, which runs no
    clean-up in the parent: on Linux the kernel sends SIGKILL (``prctl(PR_SET_PDEATHSIG)``); elsewhere, or
    if that fails, a daemon thread checks the parent's id every 0.5 s and exits when it changes."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(1, signal.SIGKILL, 0, 0, 0) == 0:  # 1: PR_SET_PDEATHSIG
                if os.getppid() != parent:  # the parent died before the call
                    os._exit(1)
                return
        except (OSError, AttributeError):
            pass

    def watch():
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="die-with-parent").start()


def _stop_children():
    """Terminate this process's worker processes (on Ctrl-C: their work is abandoned)."""
    import multiprocessing as mp

    for child in mp.active_children():
        child.kill()
    for child in mp.active_children():
        child.join(timeout=5)


def _worker(task):
    """One process: NC with its builders, then PGC plans with them on the clusters the parent sends.
    Progress (NC rounds) goes to the parent through ``ticks``."""
    cache, clusters_q, ticks, rewards, graphs, nodes, alphas, base, seed, builders, clusterings = task
    if cache:
        enable_compilation_cache()
    raw, timing = {}, {}
    if "nc" in clusterings:
        raw, timing = run_experiment(rewards, graphs, nodes, alphas, base, seed, builders, ("nc",),
                                     progress=ticks.put)
    if "pgc" in clusterings:
        D, beta, psi, gidx, al = experiment_arrays(rewards, graphs, nodes, alphas, base, seed)
        pgc_plans(builders, D, beta, psi, gidx, al, clusters_q.get(), raw, timing)
    return raw, timing


def run_parallel(workers, rewards, graphs, nodes, alphas, base, seed, cache, quiet,
                 builders=None, clusterings=("nc", "pgc")):
    """:func:`jaxdc.drp.analysis.experiment.run_experiment` split over ``workers`` processes: each takes a group of
    builders (:func:`builder_groups`) for NC and for the PGC plans. ``cache``: each worker turns on the
    persistent XLA compilation cache. Same ``(raw, timing)`` as the one-process experiment
    (tests/drp/analysis/test_parallel.py), ``raw`` sorted by key. On Ctrl-C (or SIGTERM) the worker processes are
    terminated and ``KeyboardInterrupt`` propagates; the workers themselves never see the signal. If the parent
    is killed outright (SIGKILL), the workers and the manager process die with it (:func:`die_with_parent`)."""
    import multiprocessing as mp
    import queue as queue_mod
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing.managers import SyncManager

    from tqdm import tqdm

    from jaxdc.drp.tours import BUILDERS

    builders = list(builders or BUILDERS)
    groups = builder_groups(builders, workers)
    ctx = mp.get_context("spawn")
    raw, timing = {}, {}
    total = progress_units(builders, clusterings, nodes, graphs * len(alphas))
    manager = pool = None
    try:
        with _children_ignore_ctrl_c():
            manager = SyncManager(ctx=ctx)
            manager.start(die_with_parent, (os.getpid(),))
            pool = ProcessPoolExecutor(len(groups), mp_context=ctx, initializer=die_with_parent,
                                       initargs=(os.getpid(),))
            clusters_q, ticks = manager.Queue(), manager.Queue()
            futures = [pool.submit(_worker, (cache, clusters_q, ticks, rewards, graphs, nodes, alphas, base, seed,
                                             g, clusterings)) for g in groups]
    except BaseException:
        _stop_children()
        raise
    try:
        with tqdm(total=total, desc=f"DRP rewards {rewards} ({len(groups)} processes)", disable=quiet,
                  file=sys.stderr) as bar:
            _collect(groups, clusterings, futures, clusters_q, ticks, bar, queue_mod, rewards, graphs, nodes,
                     alphas, base, seed, raw, timing)
    except BaseException:
        _stop_children()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    manager.shutdown()
    return dict(sorted(raw.items())), timing


def _collect(groups, clusterings, futures, clusters_q, ticks, bar, queue_mod, rewards, graphs, nodes, alphas, base,
             seed, raw, timing):
    """The parent's part of :func:`run_parallel`: PGC clusters to the workers, progress, then their results."""
    def drain(block=False):
        try:
            while True:
                bar.update(ticks.get(timeout=0.5) if block else ticks.get_nowait())
                block = False
        except queue_mod.Empty:
            pass

    if "pgc" in clusterings:
        D, beta, psi, gidx, al = experiment_arrays(rewards, graphs, nodes, alphas, base, seed)
        t0 = time.perf_counter()
        clusters = pgc_clusters(D, beta, psi, gidx, al, progress=lambda: (bar.update(1), drain()))
        timing["pgc_clustering"] = time.perf_counter() - t0
        for _ in groups:
            clusters_q.put(clusters)
    while not all(f.done() for f in futures):
        drain(block=True)
    drain()
    for f in futures:
        r, t = f.result()
        raw.update(r)
        timing.update(t)
