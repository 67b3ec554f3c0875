"""Pieces shared by the training command lines ``train.dcp`` and ``train.dcg``.

* argument parsing: :func:`add_a2c_arguments` (the A2C hyperparameters of
  section 4.5 / 5.5.2, the learner options beside Algorithm 10, several seeds,
  devices, and the run-control flags), and :func:`a2c_settings`, which turns
  them into :class:`~jaxdc.agents.a2c.A2CConfig` keyword arguments. Each flag's
  default is the ``A2CConfig`` field it sets, so the two cannot drift apart;
* the metrics CSV: :func:`read_rows`, :func:`write_rows` (atomic);
* :class:`TrainingRun`: the loop of a run -- a progress bar, an evaluation
  row and an orbax checkpoint every ``--eval-every`` steps, exact
  ``--resume`` from the latest checkpoint, and a stop (status ``"nan"``,
  before any checkpoint) when the loss is not finite. A subclass builds the
  trainer (:meth:`TrainingRun.parallel_trainer` spreads it over the devices
  and the seeds) and says how to evaluate.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import io
import os
import sys
import tempfile
import time

import jax
import numpy as np

from jaxdc import checkpoint
from jaxdc.agents import parallel
from jaxdc.agents.a2c import A2CConfig, lr_schedule
from jaxdc.cli.args import nonnegative_float, positive_float, positive_int, seed_list, unit_interval
from jaxdc.io import atomic_write, atomic_write_json

#: Exit status of a run stopped by a NaN loss.
EXIT_NAN = 3
#: How updates are driven: one jitted update per Python iteration, or ``n`` updates in one ``lax.scan``.
LAYOUTS = ("loop", "scan")


#: ``A2CConfig`` field -> the attribute of the parsed arguments that sets it (the flag is its dashed form).
A2C_FLAGS = {"total_steps": "steps", "num_envs": "envs", "t_max": "t_max", "lr": "lr", "gamma": "gamma",
             "entropy_coef": "entropy", "value_coef": "value_coef", "max_grad_norm": "max_grad_norm",
             "reset_slots": "reset_slots", "gae_lambda": "gae_lambda", "clip_eps": "clip_eps",
             "epochs": "epochs", "minibatches": "minibatches", "normalize_advantages": "normalize_advantages"}
#: The learner options beside Algorithm 10 (not in the thesis; docs/learning.md) and their faithful defaults.
LEARNER_OPTIONS = {f.name: f.default for f in dataclasses.fields(A2CConfig)
                   if f.name in ("gae_lambda", "clip_eps", "epochs", "minibatches", "normalize_advantages")}
_DEFAULT = {f.name: f.default for f in dataclasses.fields(A2CConfig)}


def flag(field: str) -> str:
    """The command-line flag that sets ``A2CConfig`` field ``field`` (e.g. ``"--entropy"`` for ``entropy_coef``)."""
    return "--" + A2C_FLAGS[field].replace("_", "-")


def add_a2c_arguments(p: argparse.ArgumentParser, eval_every: int = 100_000, eval_episodes: int = 500) -> None:
    """The A2C hyperparameters (defaults: the ``A2CConfig`` fields, i.e. sections 4.5 and 5.5.2), the learner
    options beside Algorithm 10, several seeds and devices, and the run-control flags."""
    d = _DEFAULT
    p.add_argument("--steps", type=positive_int("--steps"), default=d["total_steps"],
                   help="T_max: environment steps in total (the learning rate reaches 0 there)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--seeds", type=seed_list("--seeds"), default=None,
                   help="several independent runs at once (vmapped), e.g. 0,1,2; replaces --seed")
    p.add_argument("--envs", type=positive_int("--envs"), default=d["num_envs"],
                   help="parallel environments (16 threads)")
    p.add_argument("--devices", type=positive_int("--devices"), default=None,
                   help="devices to split the environment batch over (default: all; --envs must be a multiple)")
    p.add_argument("--t-max", type=positive_int("--t-max"), default=d["t_max"], help="rollout length per update")
    p.add_argument("--lr", type=positive_float("--lr"), default=d["lr"], help="initial learning rate")
    p.add_argument("--gamma", type=unit_interval("--gamma"), default=d["gamma"])
    p.add_argument("--entropy", type=nonnegative_float("--entropy"), default=d["entropy_coef"],
                   help="entropy bonus weight (default 0.01 as in A3C; 0 for the thesis' two loss terms)")
    p.add_argument("--value-coef", type=nonnegative_float("--value-coef"), default=d["value_coef"])
    p.add_argument("--max-grad-norm", type=positive_float("--max-grad-norm"), default=d["max_grad_norm"])
    p.add_argument("--reset-slots", type=positive_int("--reset-slots"), default=d["reset_slots"],
                   help="fresh initial states drawn per step (default: one per environment)")
    g = p.add_argument_group("learner options beside Algorithm 10 (not in the thesis; see docs/learning.md)")
    g.add_argument("--gae-lambda", type=unit_interval("--gae-lambda"), default=d["gae_lambda"],
                   help="lambda-returns / GAE (1: the n-step returns of Algorithm 10)")
    g.add_argument("--clip-eps", type=unit_interval("--clip-eps", open_interval=True), default=d["clip_eps"],
                   help="PPO clipping of the probability ratio (default: none, plain policy gradient)")
    g.add_argument("--epochs", type=positive_int("--epochs"), default=d["epochs"], help="passes over each rollout")
    g.add_argument("--minibatches", type=positive_int("--minibatches"), default=d["minibatches"],
                   help="shuffled minibatches per pass (must divide envs * t-max)")
    g.add_argument("--normalize-advantages", action="store_true", help="standardize advantages per minibatch")
    p.add_argument("--layout", choices=LAYOUTS, default="loop",
                   help="loop: one jitted update per Python iteration (faster on CPU); scan: updates in lax.scan")
    p.add_argument("--resume", action="store_true", help="continue from the latest checkpoint in --out")
    p.add_argument("--eval-every", type=positive_int("--eval-every"), default=eval_every,
                   help="environment steps between evaluations and checkpoints")
    p.add_argument("--eval-episodes", type=positive_int("--eval-episodes"), default=eval_episodes)
    p.add_argument("--greedy-eval", action="store_true", help="evaluate the argmax policy instead of sampling")
    p.add_argument("--keep", type=positive_int("--keep"), default=3, help="checkpoints to keep")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def a2c_settings(args, fields=tuple(A2C_FLAGS)) -> dict:
    """``A2CConfig`` keyword arguments from the parsed flags of :func:`add_a2c_arguments` (``fields``: which)."""
    return {f: getattr(args, A2C_FLAGS[f]) for f in fields}


def learner_options_set(args) -> list[str]:
    """The flags of the learner options beside Algorithm 10 that ``args`` moves off their faithful default."""
    return [flag(f) for f, default in LEARNER_OPTIONS.items() if getattr(args, A2C_FLAGS[f]) != default]


def algorithm_metadata(config) -> dict:
    """The config as checkpoint metadata; learner options at their defaults are left out, so checkpoints of
    faithful runs written before the options existed still resume."""
    return {k: v for k, v in dataclasses.asdict(config).items()
            if not (k in LEARNER_OPTIONS and v == LEARNER_OPTIONS[k])}


def check_writable(folder: str) -> None:
    """Create ``folder`` if needed; raise a ``ValueError`` naming it if it cannot be written."""
    try:
        os.makedirs(folder, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as e:
        raise ValueError(f"output folder {folder!r} is not writable: {e}") from None


def read_rows(path: str, max_updates: int) -> list[dict]:
    """The CSV rows of ``path`` up to update ``max_updates`` (a resumed run drops rows past its checkpoint)."""
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return [r for r in csv.DictReader(f) if int(r["updates"]) <= max_updates]


def write_rows(path: str, rows: list[dict], fields) -> None:
    """Write ``rows`` with the columns ``fields`` to ``path`` atomically."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, restval="", extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)
    atomic_write(path, buf.getvalue())


def tensorboard_writer(folder: str | None):
    """A tensorboardX ``SummaryWriter`` into ``folder`` (``None``: only check the import), or a clear error
    naming the extra to install."""
    try:
        from tensorboardX import SummaryWriter
    except ImportError:
        raise ValueError("--tensorboard needs tensorboardX: pip install 'jaxdc[tb]' (or tensorboardX)") from None
    return None if folder is None else SummaryWriter(folder)


class TrainingRun:
    """The loop of a training command line. A subclass sets, in its constructor:

    ``args`` (with the flags of :func:`add_a2c_arguments`), ``out``, ``ckpt_dir``,
    ``config`` (``batch_size``, ``num_updates``), ``trainer`` (``init``, ``update``,
    ``run`` of :func:`jaxdc.agents.a2c.make_train`), ``metadata`` (checked on
    ``--resume``), ``loss_metrics`` (training metrics averaged into each row) and
    ``csv_fields``; and defines :meth:`evaluate`.

    Several seeds in one vmapped program (``--seeds``) and the devices
    (``--devices``): the subclass builds its trainer through
    :meth:`parallel_trainer`, which reads both flags; :meth:`evaluate` then
    returns one dict per seed (keys from :meth:`eval_key`). Each seed gets its
    own CSV (and TensorBoard folder with ``--tensorboard``), one checkpoint
    holds all.
    """

    postfix_key = "eval_reward"
    multi = False

    def evaluate(self, params, update: int):  # pragma: no cover - abstract
        """The evaluation columns of the row at ``update`` (a list of them, one per seed, if ``multi``)."""
        raise NotImplementedError

    @property
    def run_seeds(self) -> list[int]:
        return list(getattr(self, "seeds", None) or [self.args.seed])

    def parallel_trainer(self, trainer):
        """``trainer`` spread over ``--devices`` (default all) and vmapped over ``--seeds`` (sets ``seeds``,
        ``multi`` and ``mesh``)."""
        a = self.args
        self.seeds = a.seeds or [a.seed]
        self.multi = len(self.seeds) > 1
        available = len(jax.devices())
        if a.devices is not None and a.devices > available:
            raise ValueError(f"--devices {a.devices}: JAX sees only {available} device(s)")
        devices = a.devices or available
        if a.envs % devices:
            raise ValueError(f"--envs ({a.envs}) must be divisible by the number of devices ({devices}); "
                             "change --envs or pass --devices")
        self.mesh = parallel.data_mesh(devices)
        return parallel.parallelize(trainer, self.mesh, len(self.seeds) if self.multi else None)

    def _keys(self, offset: int = 0):
        keys = [jax.random.PRNGKey(s + offset) for s in self.run_seeds]
        return jax.numpy.stack(keys) if self.multi else keys[0]

    def init_key(self):
        """The key of :meth:`trainer.init` (stacked per seed when ``multi``)."""
        return self._keys()

    def eval_key(self, update: int):
        """The evaluation key at ``update`` (stacked per seed when ``multi``; each seed's equals its single run's)."""
        base = self._keys(1_000_003)
        if self.multi:
            return jax.vmap(jax.random.fold_in, in_axes=(0, None))(base, update)
        return jax.random.fold_in(base, update)

    def place(self, state):
        """Put a restored state on the devices (as :meth:`parallel_trainer` placed it)."""
        mesh = getattr(self, "mesh", None)
        return state if mesh is None else parallel.place(state, mesh, seed_axis=self.multi)

    def paths(self) -> list[tuple[str, str]]:
        """``(metrics CSV, TensorBoard folder)`` per seed."""
        if not self.multi:
            return [(os.path.join(self.out, "metrics.csv"), os.path.join(self.out, "tb"))]
        return [(os.path.join(self.out, f"metrics-s{s}.csv"), os.path.join(self.out, "tb", f"s{s}"))
                for s in self.run_seeds]

    # -- state --------------------------------------------------------------------------
    def initial_state(self):
        """A fresh state (writes ``config.json``), or with ``--resume`` the latest checkpoint's."""
        a = self.args
        check_writable(self.out)
        state = self.trainer.init(self.init_key())
        existing = checkpoint.steps(self.ckpt_dir)
        if not a.resume:
            if existing:
                raise ValueError(f"{self.ckpt_dir} already holds checkpoints {existing}; "
                                 "pass --resume to continue or choose another --out")
            atomic_write_json(os.path.join(self.out, "config.json"), self.metadata)
            return state
        if not existing:
            raise ValueError(f"--resume: no checkpoint found in {self.ckpt_dir}")
        state, _ = checkpoint.restore(self.ckpt_dir, state, self.metadata)
        return self.place(state)

    # -- the loop -----------------------------------------------------------------------
    def train(self) -> dict:
        """Train to the end (or to a NaN loss); return the last metrics row (of the first seed) with ``"status"``
        (and ``per_seed``: ``(seed, row)`` pairs).

        The final training state is kept in ``self.final_state``.
        """
        from tqdm import tqdm

        a, cfg = self.args, self.config
        state = self.initial_state()
        update = int(np.asarray(state.update).reshape(-1)[0])
        paths = self.paths()
        rows = [read_rows(csv_path, update) for csv_path, _ in paths]
        writers = [tensorboard_writer(tb) for _, tb in paths] if getattr(a, "tensorboard", False) else []
        every = max(1, a.eval_every // cfg.batch_size)
        schedule = lr_schedule(cfg)
        bar = tqdm(total=cfg.num_updates * cfg.batch_size, initial=update * cfg.batch_size, unit="step",
                   unit_scale=True, disable=a.no_progress, dynamic_ncols=True)
        last = {"status": "done", "updates": update}
        self.final_state = state
        while update < cfg.num_updates:
            n = min(every - update % every, cfg.num_updates - update)
            t0 = time.perf_counter()
            state, metrics = self._updates(state, n, bar)
            metrics = jax.device_get(metrics)
            wall = time.perf_counter() - t0
            if not np.all(np.isfinite(metrics["loss"])):
                bar.close()
                print(f"error: the loss became NaN/inf between updates {update} and {update + n}; stopping. "
                      f"The last good checkpoint is in {self.ckpt_dir}", file=sys.stderr)
                return {"status": "nan", "updates": update}
            update += n
            evals = self.evaluate(state.params, update)
            evals = [evals] if isinstance(evals, dict) else evals
            for i, (seed_rows, ev) in enumerate(zip(rows, evals)):
                m = jax.tree_util.tree_map(lambda x: x[i], metrics) if self.multi else metrics
                episodes = int(np.sum(m["episodes"]))
                row = {"env_steps": update * cfg.batch_size, "updates": update, "wall_s": round(wall, 3),
                       "steps_per_s": round(n * cfg.batch_size / wall, 1), "lr": float(schedule(update)),
                       **{k: float(np.mean(m[k])) for k in self.loss_metrics if k in m},
                       "train_episodes": episodes,
                       "train_reward": float(np.sum(m["episode_reward_sum"]) / max(episodes, 1)), **ev}
                seed_rows.append(row)
                if writers:
                    for k, v in row.items():
                        if k not in ("env_steps", "updates") and isinstance(v, (int, float)):
                            writers[i].add_scalar(k, v, row["env_steps"])
                    writers[i].flush()
            checkpoint.save(self.ckpt_dir, update, state, self.metadata, keep=a.keep)
            for (csv_path, _), seed_rows in zip(paths, rows):
                write_rows(csv_path, seed_rows, self.csv_fields)
            last = dict(rows[0][-1], per_seed=[(seed, r[-1]) for seed, r in zip(self.run_seeds, rows)])
            bar.set_postfix({self.postfix_key: " ".join(f"{r[-1][self.postfix_key]:.3f}" for r in rows)})
            self.final_state = state
        bar.close()
        for w in writers:
            w.close()
        return dict(last, status="done")

    def _updates(self, state, n: int, bar):
        """``n`` updates; metrics ``[n]`` (``[seeds, n]`` with several seeds)."""
        if self.args.layout == "scan":
            state, metrics = self.trainer.run(state, n)
            bar.update(n * self.config.batch_size)
            return state, metrics
        history = []
        for _ in range(n):
            state, m = self.trainer.update(state)
            history.append(m)
            bar.update(self.config.batch_size)
        return state, jax.tree_util.tree_map(lambda *x: np.stack(x, axis=-1), *jax.device_get(history))
