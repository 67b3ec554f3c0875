"""The runs that make the shipped parameter files: the DCP's (``jaxdc/assets/dcp``: ``train.dcp``, then
:func:`export`) and the strong DCG collectors (``jaxdc/assets/dcg/*_strong*``: ``train.dcg --ship``).

The recipes are the presets of :mod:`jaxdc.training.presets` (each shipped DCP
network: the defaults of ``train.dcp``, i.e. the thesis' hyper-parameters of
section 4.5, seed 0, 1M steps, in the setting of the table it fills).
:func:`train_command` is the command line of one, as recorded in the shipped
metadata; :func:`train_all` runs several through the installed ``jaxdc``
command (``python -m jaxdc train dcp ...``, in child processes), and
:func:`export` writes a finished DCP run's last checkpoint with
:func:`jaxdc.pretrained.save`, its metadata holding the network, the problem,
every environment setting, the steps, the seed and the exact command.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from collections.abc import Iterable, Sequence
from typing import Any

from jaxdc import pretrained
from jaxdc.dcp import learned as learned_lib
from jaxdc.dcp.env import DCP
from jaxdc.training.metrics import numbered_rows
from jaxdc.training.presets import ALL, BEYOND, DCG_STRONG, EVERY, PPO, SHIPPED, Preset

__all__ = ["ALL", "BEYOND", "DCG_STRONG", "EVERY", "PPO", "POLL_S", "SHIPPED", "STOP_TIMEOUT", "TRAIN_EVAL", "Preset",
           "export", "export_metadata", "failure_line", "jaxdc_command", "stop_children", "train_all", "train_command"]

#: Seconds between checks of the running trainings.
POLL_S = 5


def train_command(name: str, steps: int, seed: int, runs: str) -> list[str]:
    """The ``python -m train.dcp`` (or, for a DCG entry, ``train.dcg``) command line that trains shipped
    network ``name``, as its metadata records it.

    ``steps`` applies unless the entry fixes its own ``total_steps`` (the beyond-the-thesis networks), and ``seed``
    unless it fixes its own ``seed`` (a network shipped from another seed's run).
    """
    preset = EVERY[name]
    seed = seed if preset.seed is None else preset.seed
    args = preset.flags()
    own_steps = [] if preset.total_steps is not None else ["--steps", str(steps)]
    if preset.problem == "dcg":
        return ["python", "-m", "train.dcg", *args, "--no-progress", "--seed", str(seed),
                "--out", os.path.join(runs, name), "--ship", f"jaxdc/assets/dcg/{name}.msgpack"]
    return ["python", "-m", "train.dcp", *args, *own_steps, "--seed", str(seed),
            "--out", os.path.join(runs, name), "--no-progress"]


def jaxdc_command(command: Sequence[str]) -> list[str]:
    """The command that runs ``command`` (``python -m train.dcp ...``, :func:`train_command`) with this Python's
    installed ``jaxdc`` (``python -m jaxdc train dcp ...``): the ``train/`` shims are not in the wheel."""
    if list(command[:2]) != ["python", "-m"] or not command[2].startswith("train."):
        raise ValueError(f"not a train.* command: {' '.join(command)}")
    return [sys.executable, "-m", "jaxdc", "train", command[2].split(".", 1)[1], *command[3:]]


#: The evaluation columns of ``metrics.csv`` an export records (``"train_eval"`` of the metadata).
TRAIN_EVAL = ("eval_reward", "eval_energy", "eval_rpe")
#: What a damaged ``metrics.csv`` error tells the exporter to do.
_EXPORT_FIX = "repair the file (or move it away to export without the training's last evaluation)"


def _last_row(run: str) -> tuple[str, int, dict]:
    """``(path, line, row)`` of the last row of the run's ``metrics.csv`` (``line`` 0 and ``{}`` without one); a
    damaged file is a ``ValueError`` naming it, the line and the column
    (:func:`jaxdc.training.metrics.numbered_rows`)."""
    path = os.path.join(run, "metrics.csv")
    rows = numbered_rows(path, _EXPORT_FIX)
    return (path, *rows[-1]) if rows else (path, 0, {})


def _csv_steps(text: str, where: str) -> int:
    """The ``env_steps`` of a metrics row as the metadata's ``steps``: an int >= 1 (:data:`jaxdc.metadata.COUNTS`,
    the check :func:`jaxdc.pretrained.read_metadata` applies); else a ``ValueError`` naming ``where``."""
    try:
        v: float = int(text)
    except ValueError:
        try:
            v = float(text)
        except ValueError:
            v = math.nan
    if not math.isfinite(v) or v != int(v) or v < 1:
        raise ValueError(f"{where}: {text!r} must be an int >= 1 (the exported metadata's steps); {_EXPORT_FIX}")
    return int(v)


def _csv_number(text: str, where: str) -> float:
    """A finite number of a metrics row (strict JSON has no NaN or infinity); else a ``ValueError`` naming ``where``."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not math.isfinite(v):
        raise ValueError(f"{where}: {text!r} must be a finite number (the exported metadata is strict JSON); "
                         f"{_EXPORT_FIX}")
    return v


def export_metadata(name: str, run: str, command: list[str]) -> tuple[Any, dict]:
    """``(params, metadata)`` that :func:`export` writes for ``run``, every value checked first: what the run's
    ``metrics.csv`` gives (its last row's ``env_steps`` an int >= 1, its evaluation columns finite numbers; each
    error names the file, the line and the column) and then the whole metadata with the checks
    :func:`jaxdc.pretrained.read_metadata` applies (:func:`jaxdc.pretrained.check_metadata_values`), so an export
    never writes a file its loader refuses. Nothing is written."""
    learned = learned_lib.load(run)
    meta = learned.metadata
    env = DCP(grid_size=meta["grid_size"], total_reward=meta["total_reward"])  # train.dcp's environment
    csv_path, line, last = _last_row(run)

    def where(column: str) -> str:
        return f"metrics file {csv_path}: line {line}, column {column}"

    steps = (_csv_steps(last["env_steps"], where("env_steps")) if last.get("env_steps")
             else meta["algorithm"]["total_steps"])
    metadata = {
        "net": learned.net_name, "problem": "dcp", **learned.setting(),
        "min_total_reward": meta["min_total_reward"],
        **{k: meta[k] for k in ("observation", "risk_maps", "map_seeds", "energy_range", "energy_tilt", "item_tilt",
                                   "init_fraction", "heuristic_rows", *learned_lib.BODY_KEYS, "grid_sizes",
                                   "init_from", "init_sha256") if k in meta},
        "env": {"start": env.start, "items_on_base": env.items_on_base, "idle_terminates": env.idle_terminates,
                "item_order": env.item_order},
        "steps": steps,
        "seed": meta["seed"], "algorithm": meta["algorithm"], "tables": ALL[name].description,
        "command": " ".join(command),
        "train_eval": {k: _csv_number(last[k], where(k)) for k in TRAIN_EVAL if last.get(k)},
    }
    pretrained.check_metadata_values(metadata, f"the metadata exported from run folder {run}")
    return learned.params, metadata


def export(name: str, run: str, command: list[str], out: str) -> str:
    """Export the last checkpoint of ``run`` as ``out/<name>.msgpack`` with its metadata (sections 4.4.3, 4.5),
    checked first (:func:`export_metadata`)."""
    params, metadata = export_metadata(name, run, command)
    return pretrained.save(os.path.join(out, name), params, metadata)


def failure_line(runs: str, name: str) -> str | None:
    """The last error line of a failed training's log ``runs/<name>.log`` (e.g. the refusal of a run folder in use
    by another run, naming the folder and the process), or ``None`` if there is none."""
    try:
        with open(os.path.join(runs, f"{name}.log"), encoding="utf-8", errors="replace") as f:
            lines = [line.strip() for line in f if line.strip()]
    except OSError:
        return None
    errors = [line for line in lines if "error" in line.lower()]
    found = errors or lines
    return found[-1] if found else None


#: Seconds a child training gets to exit after ``terminate()`` before it is killed.
STOP_TIMEOUT = 20


def stop_children(procs: Sequence[subprocess.Popen]) -> None:
    """Terminate the child trainings still running, wait for them, kill those that do not exit in time."""
    for proc in procs:
        if proc.poll() is None:
            proc.terminate()
    deadline = time.monotonic() + STOP_TIMEOUT
    for proc in procs:
        try:
            proc.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def train_all(names: Iterable[str], commands: dict[str, list[str]], runs: str, jobs: int) -> list[str]:
    """Run the training ``commands`` of ``names`` (:func:`train_command`, run through :func:`jaxdc_command`;
    ``jobs`` at a time, each resumed if its run folder has checkpoints, logs in ``runs/<name>.log``); the names
    whose training failed.

    An interruption (Ctrl-C, SIGTERM) stops the running children (terminate, then kill after
    :data:`STOP_TIMEOUT` s) before it propagates: no training is left running, and each child's checkpoints
    are those of an interrupted run, resumed by the next call.
    """
    t0 = time.perf_counter()
    pending, failed = list(names), []
    running: dict[str, tuple[subprocess.Popen, Any]] = {}
    os.makedirs(runs, exist_ok=True)
    try:
        while pending or running:
            while pending and len(running) < jobs:
                n = pending.pop(0)
                cmd = jaxdc_command(commands[n])
                if os.path.isdir(os.path.join(runs, n, "checkpoints")):
                    cmd.append("--resume")
                log = open(os.path.join(runs, f"{n}.log"), "w")
                print(f"training {n}: {' '.join(commands[n])}", file=sys.stderr)
                running[n] = (subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT), log)
            time.sleep(POLL_S)
            for n, (proc, log) in list(running.items()):
                if proc.poll() is not None:
                    log.close()
                    del running[n]
                    print(f"  {n}: exit {proc.returncode} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
                    if proc.returncode != 0:
                        failed.append(n)
    except BaseException:
        stop_children([proc for proc, _ in running.values()])
        for _, log in running.values():
            log.close()
        raise
    return failed
