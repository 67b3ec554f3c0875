"""Pieces shared by the training command lines (``train.dcg``; ``train.dcp`` can move onto them).

* argument parsing: :func:`positive`, :func:`nonnegative_float` and
  :func:`add_a2c_arguments` (the A2C hyperparameters of section 4.5 / 5.5.2
  and the run-control flags);
* the metrics CSV: :func:`read_rows`, :func:`write_rows` (atomic);
* :class:`TrainingRun`: the loop of a run -- a progress bar, an evaluation
  row and an orbax checkpoint every ``--eval-every`` steps, exact
  ``--resume`` from the latest checkpoint, and a stop (status ``"nan"``,
  before any checkpoint) when the loss is not finite. A subclass builds the
  trainer and says how to evaluate.
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import sys
import tempfile
import time

import jax
import numpy as np

from jaxdc import checkpoint
from jaxdc.agents.a2c import A2CConfig, lr_schedule
from jaxdc.cli import nonnegative_float, positive_float, positive_int
from jaxdc.io import atomic_write, atomic_write_json

#: Exit status of a run stopped by a NaN loss.
EXIT_NAN = 3
#: How updates are driven: one jitted update per Python iteration, or ``n`` updates in one ``lax.scan``.
LAYOUTS = ("loop", "scan")


def add_a2c_arguments(p: argparse.ArgumentParser, eval_every: int = 100_000, eval_episodes: int = 500) -> None:
    """The A2C hyperparameters (defaults of sections 4.5 and 5.5.2) and the run-control flags."""
    p.add_argument("--steps", type=positive_int("--steps"), default=1_000_000,
                   help="T_max: environment steps in total (the learning rate reaches 0 there)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--envs", type=positive_int("--envs"), default=16, help="parallel environments (16 threads)")
    p.add_argument("--t-max", type=positive_int("--t-max"), default=32, help="rollout length per update")
    p.add_argument("--lr", type=positive_float("--lr"), default=1e-4, help="initial learning rate")
    p.add_argument("--gamma", type=nonnegative_float("--gamma"), default=0.99)
    p.add_argument("--entropy", type=nonnegative_float("--entropy"), default=A2CConfig.entropy_coef,
                   help="entropy bonus weight (default 0.01 as in A3C; 0 for the thesis' two loss terms)")
    p.add_argument("--value-coef", type=nonnegative_float("--value-coef"), default=A2CConfig.value_coef)
    p.add_argument("--max-grad-norm", type=positive_float("--max-grad-norm"), default=None)
    p.add_argument("--layout", choices=LAYOUTS, default="loop",
                   help="loop: one jitted update per Python iteration (faster on CPU); scan: updates in lax.scan")
    p.add_argument("--resume", action="store_true", help="continue from the latest checkpoint in --out")
    p.add_argument("--eval-every", type=positive_int("--eval-every"), default=eval_every,
                   help="environment steps between evaluations and checkpoints")
    p.add_argument("--eval-episodes", type=positive_int("--eval-episodes"), default=eval_episodes)
    p.add_argument("--greedy-eval", action="store_true", help="evaluate the argmax policy instead of sampling")
    p.add_argument("--keep", type=positive_int("--keep"), default=3, help="checkpoints to keep")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


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

    Several seeds in one vmapped program (``train.dcp --seeds``): the subclass
    sets ``seeds`` and ``multi = True``, overrides :meth:`init_key` (stacked
    keys) and :meth:`evaluate` returns one dict per seed; each seed gets its own
    CSV (and TensorBoard folder with ``--tensorboard``), one checkpoint holds all.
    """

    postfix_key = "eval_reward"
    multi = False

    def evaluate(self, params, update: int):  # pragma: no cover - abstract
        """The evaluation columns of the row at ``update`` (a list of them, one per seed, if ``multi``)."""
        raise NotImplementedError

    @property
    def run_seeds(self) -> list[int]:
        return list(getattr(self, "seeds", None) or [self.args.seed])

    def init_key(self):
        """The key of :meth:`trainer.init` (stacked per seed when ``multi``)."""
        return jax.random.PRNGKey(self.args.seed)

    def place(self, state):
        """Put a restored state on the devices (identity unless the subclass shards it)."""
        return state

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
