"""The loop of a training run (sections 4.5, 5.5.2): evaluations, checkpoints, exact resume, NaN stop.

:class:`TrainingRun` takes its pieces explicitly: a :class:`RunControl` (the
folder, the seeds, the devices and how the loop is driven) and a
:class:`RunSpec` (the trainer, its config, the metadata, the evaluation and
the CSV columns), which :mod:`jaxdc.training.dcp` and :mod:`jaxdc.training.dcg`
build. A run holds its folder's lock while it uses it and checks a resume
before it builds its trainer (:mod:`jaxdc.training.guards`). Every
``eval_every`` environment steps the loop writes one evaluation row per seed
(``metrics.csv``, or ``metrics-sSEED.csv`` with several seeds; TensorBoard
events on request) and an orbax checkpoint of the whole training
state; ``resume`` continues from the latest checkpoint and ends exactly where an
uninterrupted run does (``resume_step``: from an earlier one); a loss or a
training state (parameters, optimiser state) that is not finite stops the run
(status ``"nan"``) before it is evaluated or checkpointed, and a restored
checkpoint is checked too, so every checkpoint stays good.

Several seeds run in one vmapped program and the environment batch is split
over the devices (:func:`spread`, :mod:`jaxdc.agents.parallel`), also those of
several processes (:mod:`jaxdc.training.distributed`): then every process steps
its shard and only process 0 evaluates and writes the run folder.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from typing import Any, Callable

import jax
import numpy as np

from jaxdc import checkpoint
from jaxdc.agents import parallel
from jaxdc.agents.common import RunConfig, Trainer, lr_schedule
from jaxdc.core import memory
from jaxdc.io import atomic_write_json, check_output_folder
from jaxdc.provenance import provenance
from jaxdc.training import guards
from jaxdc.training.distributed import is_primary
from jaxdc.training.fields import SettingError
from jaxdc.training.lock import FolderLock
from jaxdc.training.metrics import read_rows, tensorboard_writer, write_rows

#: How updates are driven: one jitted update per Python iteration, or ``n`` updates in one ``lax.scan``.
LAYOUTS = ("loop", "scan")
#: Offset of the evaluation keys' seeds from the run's seeds.
EVAL_SEED_OFFSET = 1_000_003


@dataclasses.dataclass(frozen=True)
class RunControl:
    """How a run is driven, whatever it trains.

    Attributes:
      out: the run folder (``config.json``, metrics, ``checkpoints/``).
      seeds: the runs' seeds; more than one trains them in one vmapped program.
      devices: devices to split the environment batch over (``None``: all).
      resume: continue from the latest checkpoint in ``out``.
      resume_step: with ``resume``, continue from this checkpoint instead (the later ones are deleted).
      eval_every: environment steps between evaluations and checkpoints.
      keep: checkpoints to keep.
      layout: one of :data:`LAYOUTS`.
      progress: show a progress bar.
      tensorboard: also write the metrics as TensorBoard event files into ``out/tb``.
    """

    out: str
    seeds: tuple[int, ...] = (0,)
    devices: int | None = None
    resume: bool = False
    resume_step: int | None = None
    eval_every: int = 100_000
    keep: int = 3
    layout: str = "loop"
    progress: bool = True
    tensorboard: bool = False

    def __post_init__(self) -> None:
        if self.resume_step is not None and not self.resume:
            raise SettingError(f"{{0}} {self.resume_step} applies only with {{1}}", "resume_step", "resume")

    @property
    def multi(self) -> bool:
        """Several seeds in one vmapped program."""
        return len(self.seeds) > 1

    @property
    def ckpt_dir(self) -> str:
        return os.path.join(self.out, "checkpoints")


@dataclasses.dataclass(frozen=True)
class RunSpec:
    """What a problem gives the loop.

    Attributes:
      config: the algorithm's config (``batch_size``, ``num_updates``).
      trainer: the trainer, already spread by :func:`spread` (``init``, ``update``, ``run``).
      mesh: the mesh :func:`spread` placed it on.
      metadata: the run's metadata (``config.json``; checked on resume after :func:`jaxdc.metadata.upgrade`).
      evaluate: ``(params, key) -> [columns]``, one dict of evaluation columns per seed (keys from
        :meth:`TrainingRun.eval_key`).
      loss_metrics: training metrics averaged into each row.
      csv_fields: the columns of the metrics CSV.
      postfix_key: the column shown beside the progress bar.
    """

    config: RunConfig
    trainer: Trainer
    mesh: Any
    metadata: dict
    evaluate: Callable[[Any, Any], list]
    loss_metrics: tuple[str, ...]
    csv_fields: tuple[str, ...]
    postfix_key: str = "eval_reward"


def spread(trainer: Trainer, control: RunControl, num_envs: int, groups: int = 1) -> tuple[Trainer, Any]:
    """``(trainer, mesh)``: ``trainer`` split over ``control.devices`` (default all) and vmapped over its seeds;
    ``groups``: the environment groups (grid sizes) ``num_envs`` is split over, each split over the devices."""
    available = len(jax.devices())
    if control.devices is not None and control.devices > available:
        raise SettingError(f"{{0}} {control.devices}: JAX sees only {available} device(s)", "devices")
    devices = control.devices or available
    if num_envs % devices:
        raise SettingError(f"{{0}} ({num_envs}) must be divisible by the number of devices ({devices}); "
                           "change {0} or pass {1}", "num_envs", "devices")
    share = num_envs // groups
    if share % devices:
        raise SettingError(f"{{0}} ({num_envs}) split over the {groups} grid sizes of {{1}} gives {share} environments "
                           f"per size, which must be divisible by the number of devices ({devices}); change {{0}} or "
                           "pass {2}", "num_envs", "grid_sizes", "devices")
    mesh = parallel.data_mesh(devices)
    return parallel.parallelize(trainer, mesh, len(control.seeds) if control.multi else None), mesh


def csv_paths(control: RunControl) -> list[tuple[str, str]]:
    """``(metrics CSV, TensorBoard folder)`` per seed of a run."""
    if not control.multi:
        return [(os.path.join(control.out, "metrics.csv"), os.path.join(control.out, "tb"))]
    return [(os.path.join(control.out, f"metrics-s{s}.csv"), os.path.join(control.out, "tb", f"s{s}"))
            for s in control.seeds]


#: The files a fresh run writes into its run folder besides the metrics (a resume writes neither).
FRESH_FILES = ("config.json", "provenance.json")


def run_folders(control: RunControl) -> list[tuple[str, str]]:
    """``(what, folder)`` of the folders a run writes inside its run folder: ``checkpoints/`` and, with
    ``tensorboard``, ``tb/`` (and ``tb/sSEED`` per seed)."""
    folders = [("checkpoints folder", control.ckpt_dir)]
    if control.tensorboard:
        tbs = [tb for _, tb in csv_paths(control)]
        tbs = list(dict.fromkeys([os.path.join(control.out, "tb"), *tbs]))  # tb/, then tb/sSEED with several seeds
        folders += [("tensorboard folder (--tensorboard)", tb) for tb in tbs]
    return folders


def check_run_folder(control: RunControl, what: str = "run folder", inputs: Any = None) -> None:
    """Refuse, before any work (``ValueError`` naming the path and the reason), a run folder whose outputs cannot
    be written or must not be: the folder itself (:func:`jaxdc.io.check_output_folder`), each file the run writes
    into it (``config.json`` and ``provenance.json`` of a fresh run, the metrics CSVs: no folder or dangling
    symbolic link at the name, none of the command's ``inputs``), and each folder it writes inside it
    (:func:`run_folders`: a file or a dangling symbolic link at the name is refused).

    One run per folder: the lock (:mod:`jaxdc.training.lock`) covers the run folder only, so every folder a run
    writes into must resolve inside it. A ``checkpoints/`` (or ``tb/``) that is a symbolic link to a folder
    outside the run folder, e.g. to another run's ``checkpoints/``, is refused: a resume there would delete and
    rewrite the checkpoints of a run that another process may be training. (A link to a folder inside the run
    folder is fine.)"""
    out = control.out
    names = [] if control.resume else list(FRESH_FILES)
    names += [os.path.basename(csv_path) for csv_path, _ in csv_paths(control)]
    check_output_folder(out, what, files=names, inputs=inputs)
    top = os.path.realpath(out)
    for name, folder in run_folders(control):
        check_output_folder(folder, f"{what}'s {name}")
        real = os.path.realpath(folder)
        if not real.startswith(top.rstrip(os.sep) + os.sep):
            raise ValueError(f"{what}'s {name} {folder!r} resolves to {real!r}, outside the run folder {out!r} "
                             "(a symbolic link): the run folder's lock would not cover it; remove the link or "
                             f"choose another {what}")


#: A rollout's observations are held as transitions, then as the network's input and its gradient: about this
#: many copies of ``seeds * num_envs * t_max`` observations are alive at once during an update.
BATCH_COPIES = 4


def check_batch_fits(config: RunConfig, env: Any, env_params: Any, seeds: int = 1) -> None:
    """``MemoryError`` before any compilation if a rollout batch (``seeds * num_envs * t_max`` observations,
    :data:`BATCH_COPIES` copies) cannot fit in the device's memory; the message says what to lower."""
    obs = jax.eval_shape(env.reset_env, jax.random.PRNGKey(0), env_params)[0]
    needed = BATCH_COPIES * seeds * config.num_envs * (config.t_max + 1) * memory.tree_bytes(obs)
    memory.check_fits(needed, f"a rollout batch of {seeds} x {config.num_envs} environments x {config.t_max} "
                              "steps", "num_envs or t_max (or the number of seeds)")


def check_evaluation_fits(run: TrainingRun, evaluate: Callable) -> None:
    """Trace (without running) ``evaluate(params, key)`` of ``run``, so that the memory check of its episodes
    (:func:`jaxdc.core.rollout.run_episodes`) refuses a too large ``eval_episodes`` before training starts."""
    params = jax.eval_shape(run.trainer.init, run.init_key()).params
    jax.eval_shape(evaluate, params, run.eval_key(0))


class TrainingRun:
    """One training run: :class:`RunControl` and :class:`RunSpec` in, :meth:`train` runs it.

    Each seed gets its own CSV (and TensorBoard folder), one checkpoint holds all seeds. A problem's run calls
    :meth:`claim` before it builds its trainer; :meth:`train` claims the folder itself otherwise, and releases it
    when it ends, however it ends.
    """

    _lock: FolderLock | None = None

    def __init__(self, control: RunControl, spec: RunSpec) -> None:
        if control.layout not in LAYOUTS:
            raise ValueError(f"layout must be one of {LAYOUTS}, got {control.layout!r}")
        if control.tensorboard:
            tensorboard_writer(None)  # fail before any work if tensorboardX is missing
        self.control, self.spec = control, spec
        self.final_state: Any = None

    def claim(self, control: RunControl, metadata: dict) -> None:
        """Check the run folder's outputs (:func:`check_run_folder`), lock it and check a resume
        (:func:`jaxdc.training.guards.claim`): a refusal comes at once."""
        if self._lock is None or not self._lock.held:
            check_run_folder(control)  # before the lock: a refused folder is left as it was
            self._lock = guards.claim(control, metadata, [p for p, _ in csv_paths(control)], primary=is_primary())

    # the pieces, by name
    @property
    def config(self) -> Any:
        return self.spec.config

    @property
    def trainer(self) -> Trainer:
        return self.spec.trainer

    @property
    def metadata(self) -> dict:
        return self.spec.metadata

    @property
    def out(self) -> str:
        return self.control.out

    @property
    def ckpt_dir(self) -> str:
        return self.control.ckpt_dir

    @property
    def seeds(self) -> list[int]:
        return list(self.control.seeds)

    @property
    def multi(self) -> bool:
        return self.control.multi

    def _keys(self, offset: int = 0) -> jax.Array:
        keys = [jax.random.PRNGKey(s + offset) for s in self.control.seeds]
        return jax.numpy.stack(keys) if self.multi else keys[0]

    def init_key(self) -> jax.Array:
        """The key of ``trainer.init`` (stacked per seed when several)."""
        return self._keys()

    def eval_key(self, update: int) -> jax.Array:
        """The evaluation key at ``update`` (stacked per seed; each seed's equals its single run's)."""
        base = self._keys(EVAL_SEED_OFFSET)
        if self.multi:
            return jax.vmap(jax.random.fold_in, in_axes=(0, None))(base, update)
        return jax.random.fold_in(base, update)

    def place(self, state: Any) -> Any:
        """Put a restored state on the devices (as :func:`spread` placed the trainer's)."""
        mesh = self.spec.mesh
        return state if mesh is None else parallel.place(state, mesh, seed_axis=self.multi)

    def paths(self) -> list[tuple[str, str]]:
        """``(metrics CSV, TensorBoard folder)`` per seed."""
        return csv_paths(self.control)

    # -- state --------------------------------------------------------------------------
    def initial_state(self) -> Any:
        """A fresh state (writes ``config.json``), or with ``resume`` the latest checkpoint's."""
        check_run_folder(self.control, "output folder")
        if is_primary():  # with several processes, only process 0 writes
            os.makedirs(self.out, exist_ok=True)
        state = self.trainer.init(self.init_key())
        existing = checkpoint.steps(self.ckpt_dir)
        if not self.control.resume:
            if existing:
                raise SettingError(f"{SettingError.text(self.ckpt_dir)} already holds checkpoints {existing}; "
                                   "pass {0} to continue or choose another {1}", "resume", "out")
            if is_primary():  # with several processes, only process 0 writes
                for name, record in zip(FRESH_FILES, (self.metadata, provenance())):
                    path = os.path.join(self.out, name)
                    with checkpoint.writing(path):  # an error names the file, not the folder
                        atomic_write_json(path, record)
            return state
        return self.place(guards.resume(self.control, parallel.host(state), self.metadata, primary=is_primary()))

    # -- the loop -----------------------------------------------------------------------
    def train(self) -> dict:
        """Train to the end (or to a NaN loss or state); return the last metrics row (of the first seed) with
        ``"status"`` (and ``per_seed``: ``(seed, row)`` pairs).

        The final training state is kept in ``self.final_state``. The run folder is locked meanwhile.
        """
        self.claim(self.control, self.metadata)
        try:
            return self._train()
        finally:
            if self._lock is not None:
                self._lock.release()

    def _train(self) -> dict:
        from tqdm import tqdm

        c, cfg, spec = self.control, self.config, self.spec
        state = self.initial_state()
        update = int(np.asarray(state.update).reshape(-1)[0])
        paths = self.paths()
        rows = [read_rows(csv_path, update) for csv_path, _ in paths]
        writers = [tensorboard_writer(tb) for _, tb in paths] if c.tensorboard else []
        every = max(1, c.eval_every // cfg.batch_size)
        schedule = lr_schedule(cfg)
        bar = tqdm(total=cfg.num_updates * cfg.batch_size, initial=update * cfg.batch_size, unit="step",
                   unit_scale=True, disable=not c.progress or not is_primary(), dynamic_ncols=True)
        last = {"status": "done", "updates": update}
        self.final_state = state
        if c.resume and update >= cfg.num_updates:
            print(f"resume: the run in {self.out} is already finished ({update * cfg.batch_size} environment "
                  f"steps, {update} updates; its last checkpoint is in {self.ckpt_dir}); nothing to train",
                  file=sys.stderr)
        while update < cfg.num_updates:
            n = min(every - update % every, cfg.num_updates - update)
            t0 = time.perf_counter()
            state, metrics = self._updates(state, n, bar)
            metrics = jax.device_get(metrics)
            wall = time.perf_counter() - t0
            whole = parallel.host(state)  # several processes: all take part, each gets the whole state
            problem = ("the loss became NaN/inf" if not np.all(np.isfinite(metrics["loss"]))
                       else guards.state_problem(whole))
            if problem:
                bar.close()
                saved = checkpoint.latest_step(self.ckpt_dir)
                where = (f"The last good checkpoint (update {saved}) is in {self.ckpt_dir}" if saved is not None
                         else "No checkpoint was written yet (the first comes after the first evaluation)")
                print(f"error: {problem} between updates {update} and {update + n}; stopping (NaN). {where}",
                      file=sys.stderr)
                return {"status": "nan", "updates": update}
            update += n
            self.final_state = whole
            if not is_primary():  # the others only step their environments
                continue
            evals = spec.evaluate(whole.params, self.eval_key(update))
            for i, (seed_rows, ev) in enumerate(zip(rows, evals)):
                # the lambda runs at once (tree_map), with this iteration's i
                m = jax.tree_util.tree_map(lambda x: x[i], metrics) if self.multi else metrics  # noqa: B023
                episodes = int(np.sum(m["episodes"]))
                row = {"env_steps": update * cfg.batch_size, "updates": update, "wall_s": round(wall, 3),
                       "steps_per_s": round(n * cfg.batch_size / wall, 1), "lr": float(schedule(update)),
                       **{k: float(np.mean(m[k])) for k in spec.loss_metrics if k in m},
                       "train_episodes": episodes,
                       "train_reward": float(np.sum(m["episode_reward_sum"]) / max(episodes, 1)), **ev}
                seed_rows.append(row)
                if writers:
                    for k, v in row.items():
                        if k not in ("env_steps", "updates") and isinstance(v, (int, float)):
                            writers[i].add_scalar(k, v, row["env_steps"])
                    writers[i].flush()
            # metrics first: a run stopped between the two resumes from the previous checkpoint and drops the
            # rows past it, so the CSV and the checkpoints always agree
            for (csv_path, _), seed_rows in zip(paths, rows):
                write_rows(csv_path, seed_rows, spec.csv_fields)
            checkpoint.save(self.ckpt_dir, update, whole, self.metadata, keep=c.keep)
            last = dict(rows[0][-1], per_seed=[(seed, r[-1]) for seed, r in zip(self.seeds, rows)])
            bar.set_postfix({spec.postfix_key: " ".join(f"{r[-1][spec.postfix_key]:.3f}" for r in rows)})
        bar.close()
        for w in writers:
            w.close()
        return dict(last, status="done")

    def _updates(self, state: Any, n: int, bar: Any) -> tuple[Any, Any]:
        """``n`` updates; metrics ``[n]`` (``[seeds, n]`` with several seeds)."""
        if self.control.layout == "scan":
            state, metrics = self.trainer.run(state, n)
            bar.update(n * self.config.batch_size)
            return state, metrics
        history = []
        for _ in range(n):
            state, m = self.trainer.update(state)
            history.append(m)
            bar.update(self.config.batch_size)
        return state, jax.tree_util.tree_map(lambda *x: np.stack(x, axis=-1), *jax.device_get(history))
