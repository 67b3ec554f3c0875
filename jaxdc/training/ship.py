"""The runs that make the shipped parameter files: the DCP's (``jaxdc/assets/dcp``: ``train.dcp``, then
:func:`export`) and the strong DCG collectors (``jaxdc/assets/dcg/*_strong*``: ``train.dcg --ship``).

Each shipped DCP network is trained with the defaults of ``python -m train.dcp``
(the thesis' hyper-parameters, section 4.5), seed 0, 1M steps, in the setting
of the table it fills (section 4.5: the ENN of Table 4.3 also plays Tables 4.6
and 4.8; Tables 4.4, 4.5 and 4.7 have their own ENNs; the linear learner and
EQN are trained in the setting of Table 4.3). The presets are the command-line
arguments of each entry (:data:`SHIPPED`, :data:`BEYOND`, :data:`DCG_STRONG`);
:func:`train_command` is the command of one, :func:`train_all` runs several in
subprocesses, and :func:`export` writes a finished DCP run's last checkpoint
with :func:`jaxdc.pretrained.save`, its metadata holding the network, the
problem, every environment setting, the steps, the seed and the exact command.
"""

from __future__ import annotations

import csv
import os
import subprocess
import sys
import time

from jaxdc import pretrained
from jaxdc.dcp import learned as learned_lib
from jaxdc.dcp.env import DCP

#: name of the shipped file -> (the tables it fills, train.dcp arguments of its setting)
SHIPPED = {
    "enn": ("4.3, 4.6, 4.8", ["--net", "enn", "--risk", "high", "--energy", "8", "16"]),
    "enn_medium": ("4.4", ["--net", "enn", "--risk", "medium", "--energy", "8", "16"]),
    "enn_low": ("4.5", ["--net", "enn", "--risk", "low", "--energy", "8", "16"]),
    "enn_energy16_32": ("4.7", ["--net", "enn", "--risk", "high", "--energy", "16", "32"]),
    "linear": ("4.9", ["--net", "linear", "--risk", "high", "--energy", "8", "16"]),
    "eqn": ("4.10", ["--net", "eqn", "--risk", "high", "--energy", "8", "16"]),
}
#: Beyond the thesis, shipped: the best learners of the two goals of docs/learning.md. ``enn_long``: the
#: faithful A2C in Table 4.3's setting, trained 16M steps instead of 1M (goal: >= 10% above the thesis' ENN
#: reward). ``enn_single_item``: the best single-item learner (goal: >= 97% of the exact optimum of Table
#: 4.8's setting, ``jaxdc/dcp/optimal.py``); the thesis reuses the Table 4.3 ENN there, this one is trained on
#: the single-item setting itself and evaluated greedily (``eval.dcp --greedy``). ``enn_mix``: one ENN at the
#: thesis' 1M steps for Tables 4.3, 4.6 and 4.8, trained on episodes of 1..30 units (``--min-total-reward 1``)
#: with Adam at 3e-4 (docs/learning.md, "At the thesis' 1M steps").
BEYOND = {
    "enn_long": ("4.3 (beyond the thesis: 16M steps)",
                 ["--net", "enn", "--risk", "high", "--energy", "8", "16",
                  "--steps", "16000000", "--eval-every", "2000000", "--eval-episodes", "2000"]),
    "enn_single_item": ("4.8 (beyond the thesis: trained on one item)",
                        ["--net", "enn", "--risk", "high", "--total-reward", "1", "--energy", "8", "16",
                         "--steps", "4000000", "--eval-every", "1000000", "--eval-episodes", "2000", "--greedy-eval"]),
    "enn_mix": ("4.3, 4.6, 4.8 (beyond the thesis: 1..30 units per training episode, lr 3e-4)",
                ["--net", "enn", "--risk", "high", "--energy", "8", "16", "--min-total-reward", "1", "--lr", "3e-4",
                 "--eval-episodes", "2000"]),
}
#: The PPO-style option of ``train.dcp`` (docs/learning.md, "The PPO-style option at 1M steps"), the same
#: options for every table: the best learners at the thesis' 1M steps.
PPO = ["--envs", "32", "--t-max", "32", "--lr", "3e-4", "--clip-eps", "0.2", "--epochs", "4", "--minibatches", "4",
       "--gae-lambda", "0.95", "--normalize-advantages", "--reset-slots", "4",
       "--eval-every", "1000000", "--eval-episodes", "4000"]
BEYOND.update({  # the setting of the faithful ENN of the same tables, then the PPO options
    "enn_ppo": ("4.3, 4.6 (beyond the thesis: the PPO-style option)", [*SHIPPED["enn"][1], *PPO]),
    "enn_ppo_low": ("4.5 (beyond the thesis: the PPO-style option)", [*SHIPPED["enn_low"][1], *PPO]),
    "enn_ppo_energy16_32": ("4.7 (beyond the thesis: the PPO-style option)", [*SHIPPED["enn_energy16_32"][1], *PPO]),
    "enn_ppo_mix": ("4.3, 4.6, 4.8 (beyond the thesis: the PPO-style option, 1..30 units per training episode)",
                    [*SHIPPED["enn"][1], "--min-total-reward", "1", *PPO]),
})
#: The strong DCG collectors (docs/dcg.md, "Strong collectors"; beyond the thesis): the PPO-style options at
#: lr 1e-3, 3M steps (``NET_strong``) and the same recipe at the thesis' 1M steps (``NET_strong_1m``, Fig. 5.6).
#: ``train.dcg --ship`` writes each file itself.
DCG_STRONG_RECIPE = ["--envs", "32", "--t-max", "32", "--lr", "1e-3", "--clip-eps", "0.2", "--epochs", "4",
                     "--minibatches", "4", "--gae-lambda", "0.95", "--normalize-advantages", "--reset-slots", "4",
                     "--eval-every", "1000000", "--eval-episodes", "2000"]
#: The strong DCG collectors: name -> (the figures each fills, train.dcg arguments): ``NET_strong`` (3M steps) and
#: ``NET_strong_1m`` (1M) for each network, then ``omn_conn_strong_areas``.
DCG_STRONG = {f"{net}_strong{tag}": (figures, ["--net", net, "--steps", steps, *DCG_STRONG_RECIPE])
              for net in ("vnn", "imnn", "emnn", "omn_conn")
              for tag, steps, figures in (("", "3000000", "5.11, 5.16 (beyond the thesis: the strong recipe, 3M)"),
                                          ("_1m", "1000000", "5.6 (beyond the thesis: the strong recipe, 1M)"))}
#: One OMN+CoNN for every reward-area size (Fig. 5.11; beyond the thesis): the recipe for 5M steps on one item in
#: a square whose size each episode draws from 1..4 (``--min-reward-area``).
DCG_STRONG["omn_conn_strong_areas"] = (
    "5.11 (beyond the thesis: one network for reward-area sizes 1-4)",
    ["--net", "omn_conn", "--steps", "5000000", *DCG_STRONG_RECIPE, "--reward-area", "4", "--min-reward-area", "1"])
ALL = {**SHIPPED, **BEYOND}
#: Seconds between checks of the running trainings.
POLL_S = 5
EVERY = {**ALL, **DCG_STRONG}


def train_command(name: str, steps: int, seed: int, runs: str) -> list[str]:
    """The ``python -m train.dcp`` (or, for a DCG entry, ``train.dcg``) command line that trains shipped
    network ``name``.

    ``steps`` applies unless the entry fixes its own ``--steps`` (the beyond-the-thesis networks).
    """
    args = EVERY[name][1]
    own_steps = [] if "--steps" in args else ["--steps", str(steps)]
    if name in DCG_STRONG:
        return ["python", "-m", "train.dcg", *args, "--no-progress", "--seed", str(seed),
                "--out", os.path.join(runs, name), "--ship", f"jaxdc/assets/dcg/{name}.msgpack"]
    return ["python", "-m", "train.dcp", *args, *own_steps, "--seed", str(seed),
            "--out", os.path.join(runs, name), "--no-progress"]


def _last_row(run: str) -> dict:
    path = os.path.join(run, "metrics.csv")
    if not os.path.exists(path):
        return {}
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return rows[-1] if rows else {}


def export(name: str, run: str, command: list[str], out: str) -> str:
    """Export the last checkpoint of ``run`` as ``out/<name>.msgpack`` with its metadata (sections 4.4.3, 4.5)."""
    learned = learned_lib.load(run)
    meta = learned.metadata
    env = DCP(grid_size=meta["grid_size"], total_reward=meta["total_reward"])  # train.dcp's environment
    last = _last_row(run)
    metadata = {
        "net": learned.net_name, "problem": "dcp", **learned.setting(),
        "min_total_reward": meta["min_total_reward"],
        "env": {"start": env.start, "items_on_base": env.items_on_base, "idle_terminates": env.idle_terminates,
                "item_order": env.item_order},
        "steps": int(last.get("env_steps") or meta["algorithm"]["total_steps"]),
        "seed": meta["seed"], "algorithm": meta["algorithm"], "tables": ALL[name][0],
        "command": " ".join(command),
        "train_eval": {k: float(last[k]) for k in ("eval_reward", "eval_energy", "eval_rpe") if last.get(k)},
    }
    return pretrained.save(os.path.join(out, name), learned.params, metadata)


#: Seconds a child training gets to exit after ``terminate()`` before it is killed.
STOP_TIMEOUT = 20


def stop_children(procs) -> None:
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


def train_all(names, commands: dict, runs: str, jobs: int) -> list[str]:
    """Run the training ``commands`` of ``names`` (``jobs`` at a time, each resumed if its run folder has
    checkpoints, logs in ``runs/<name>.log``); the names whose training failed.

    An interruption (Ctrl-C, SIGTERM) stops the running children (terminate, then kill after
    :data:`STOP_TIMEOUT` s) before it propagates: no training is left running, and each child's checkpoints
    are those of an interrupted run, resumed by the next call.
    """
    t0 = time.perf_counter()
    pending, running, failed = list(names), {}, []
    os.makedirs(runs, exist_ok=True)
    try:
        while pending or running:
            while pending and len(running) < jobs:
                n = pending.pop(0)
                cmd = [sys.executable] + commands[n][1:]
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
