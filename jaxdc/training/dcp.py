"""A DCP training run: A2C (sections 4.4.3, 4.5) for the actor-critics, n-step Q-learning for EQN (4.5.5).

:class:`DCPSettings` holds the problem's side of a run (network, environment
setting, the algorithm's config, the evaluation); :class:`DCPRun` builds the
environment, the heuristics of section 4.4.3, the trainer (spread over the
devices and seeds of its :class:`~jaxdc.training.loop.RunControl`), the
metadata and the evaluation, and runs them with the loop of
:class:`~jaxdc.training.loop.TrainingRun`. Evaluation always drops
``total_reward`` units (the setting of the tables), also when training draws
the number from ``min_total_reward..total_reward``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from typing import Any

import jax

from jaxdc.agents import a2c, nstep_q
from jaxdc.core import grid
from jaxdc.core.paths import safest_paths
from jaxdc.core.rollout import run_episodes
from jaxdc.core.tree_check import digest
from jaxdc.dcp import env as dcp_env
from jaxdc.dcp import instances, learned, navigators
from jaxdc.dcp.evaluate import summarize
from jaxdc.metadata import FORMAT, check_run, recorded_pair, run_settings
from jaxdc.nets import DCP_NETS, NSTEP_Q
from jaxdc.nets.registry import body_options
from jaxdc.training.fields import SettingError, check_tilt_has_range
from jaxdc.training.instances import check_instance_settings, instance_metadata, training_params
from jaxdc.training.loop import RunControl, RunSpec, TrainingRun, check_batch_fits, check_evaluation_fits, spread
from jaxdc.training.warm_start import check_init_from, check_same_setting, init_metadata

#: Networks (the registry :data:`jaxdc.nets.registry.DCP_NETS`): the actor-critics train with A2C, EQN with
#: n-step Q-learning.
NETS = tuple(DCP_NETS)
LOSS_METRICS = ("loss", "policy_loss", "value_loss", "entropy", "q_mean", "epsilon")
CSV_FIELDS = ("env_steps", "updates", "wall_s", "steps_per_s", "lr", *LOSS_METRICS, "train_episodes",
              "train_reward", "eval_reward", "eval_reward_sd", "eval_energy", "eval_rpe")


@dataclasses.dataclass(frozen=True)
class DCPSettings:
    """The problem's side of a DCP run.

    Attributes:
      net: one of :data:`NETS`.
      config: ``A2CConfig`` (actor-critics) or ``QConfig`` (EQN).
      risk, grid_size, total_reward, energy, max_steps: the environment setting (Table 4.2, section 4.5).
      min_total_reward: each training episode drops a number of units drawn from ``min..total_reward``
        (beyond the thesis); ``None``: always ``total_reward``.
      item_tilt: with ``min_total_reward``, 0 (uniform) or a power-law tilt of the draw of the unit count
        (:class:`jaxdc.dcp.env.DCP`'s ``item_tilt``; a positive tilt weights the episodes with few items; beyond
        the thesis).
      eval_episodes: episodes per evaluation.
      greedy_eval: evaluate the argmax policy (EQN: epsilon 0).
      eval_epsilon: EQN's evaluation epsilon (section 4.5.5: 0.05).
      observation: ``"thesis"`` or ``"general"`` (:data:`jaxdc.dcp.env.OBSERVATIONS`).
      risk_maps, map_seeds, energy_range, init_fraction: per-episode instances (beyond the thesis;
        :func:`jaxdc.training.instances.training_params`): each episode draws its map from the
        ``map_seeds = (start, count)`` maps of the named generator (``risk_maps``, one of
        :data:`jaxdc.core.generators.GENERATORS`; ``None``: the ``risk`` preset) and its maximum energy from
        ``energy_range`` (``None``: ``energy``), starting with ``init_fraction`` of it.
      energy_tilt: with ``energy_range``, 0 (uniform) or a power-law tilt of the draw of the maximum energy
        (:func:`jaxdc.core.energy.draw_max_energy`; a positive tilt weights the small budgets; beyond the thesis).
      init_from: ``None`` (a fresh initialisation, as the thesis) or a trained actor-critic of the run's network,
        grid size and observation -- a shipped name, a ``.msgpack`` or a ``train.dcp`` run folder -- whose
        parameters start the run (a warm start, beyond the thesis: :func:`start_params`). Not for EQN.
      grid_sizes: ``None`` (one grid size, ``grid_size``) or several distinct sizes, ``grid_size`` among them, to
        train on at once (beyond the thesis; docs/generalisation.md, "Several grid sizes at once"): the ``num_envs``
        environments are split evenly over the sizes, each drawing its instances as a run of that size would
        (:func:`~jaxdc.agents.a2c.make_train`'s ``extra_envs``); evaluation stays on ``grid_size``. Needs a body
        pooled over the cells (``body_pool``) and an actor-critic.
      heuristic_rows: the ENN heuristic rows ENN or EQN reads: 10 (the thesis' ten, section 4.4.3) or 11, which
        adds Safe-Budget (beyond the thesis; :func:`jaxdc.dcp.navigators.safe_budget_action`: the route to LPG's
        item that fits the energy).
      body_features, body_hidden: the filter counts of the convolutional layers and the hidden units of the body of
        ENN, EQN or the CNN (``None``: the thesis' ``(32, 16)`` and 256, section 4.5; beyond the thesis, a wider
        body for a network that plays many maps and budgets: :func:`jaxdc.nets.registry.body_options`).
      body_pool: how the body reduces the grid: ``None`` (flattened, the thesis) or one of
        :data:`jaxdc.nets.body.POOLS` (``"mean_max"``, beyond the thesis: pooled over the cells, so the network
        plays every grid size).
    """

    net: str
    config: a2c.A2CConfig | nstep_q.QConfig
    risk: str = "high"
    grid_size: int = 8
    total_reward: int = 30
    min_total_reward: int | None = None
    energy: tuple[float, float] = (8.0, 16.0)
    max_steps: int = 1000
    eval_episodes: int = 500
    greedy_eval: bool = False
    eval_epsilon: float = nstep_q.EVAL_EPSILON
    observation: str = "thesis"
    risk_maps: str | None = None
    map_seeds: tuple[int, int] = (0, 1024)
    energy_range: tuple[float, float] | None = None
    init_fraction: float = 0.5
    init_from: str | None = None
    energy_tilt: float = 0.0
    body_features: tuple[int, ...] | None = None
    body_hidden: int | None = None
    body_pool: str | None = None
    item_tilt: float = 0.0
    heuristic_rows: int = 10
    grid_sizes: tuple[int, ...] | None = None

    @property
    def per_episode(self) -> bool:
        """Whether episodes draw their own instance (a map set or a budget range)."""
        return self.risk_maps is not None or self.energy_range is not None

    def __post_init__(self) -> None:
        if self.net not in NETS:
            raise ValueError(f"net must be one of {NETS}, got {self.net!r}")
        want = nstep_q.QConfig if self.uses_q_learning else a2c.A2CConfig
        if not isinstance(self.config, want):
            raise TypeError(f"net {self.net!r} trains with a {want.__name__}, got {type(self.config).__name__}")
        check_instance_settings(self)
        object.__setattr__(self, "item_tilt", check_tilt_has_range(self.item_tilt, self.min_total_reward,
                                                                   "item_tilt", "min_total_reward"))
        sized = body_options("dcp", self.net, self.body_features, self.body_hidden, self.body_pool)
        for k in learned.BODY_KEYS:  # the set ones as checked (plain ints for a list or numpy ints from a file)
            if getattr(self, k) is not None:
                object.__setattr__(self, k, sized[k])
        object.__setattr__(self, "heuristic_rows", navigators.check_rows(self.heuristic_rows, "heuristic_rows"))
        if self.heuristic_rows != 10 and not DCP_NETS[self.net].uses_heuristics:
            raise ValueError(f"heuristic_rows={self.heuristic_rows}: network {self.net!r} reads no heuristics "
                             f"(ENN and EQN do)")
        if self.grid_sizes is not None:
            object.__setattr__(self, "grid_sizes", check_grid_sizes(self))
        check_init_from(self.init_from)
        if self.init_from is not None and self.uses_q_learning:
            raise ValueError(f"init_from={self.init_from!r}: a warm start applies to the actor-critics (A2C); "
                             f"{self.net!r} trains with n-step Q-learning")

    @property
    def uses_q_learning(self) -> bool:
        """Whether the network trains with n-step Q-learning (EQN) rather than A2C."""
        return DCP_NETS[self.net].algorithm == NSTEP_Q

    def body(self) -> dict[str, Any]:
        """The body fields (``body_features``, ``body_hidden``, ``body_pool``) that are set: the metadata records
        them, and they are keyword arguments of :func:`jaxdc.nets.registry.build`."""
        return {k: getattr(self, k) for k in learned.BODY_KEYS if getattr(self, k) is not None}

    def network_options(self) -> dict[str, Any]:
        """What the metadata records about the network's shape beyond its name: the body fields that are set and
        ``heuristic_rows`` when it is not the thesis' 10 (:func:`jaxdc.dcp.learned.make_network` reads them)."""
        return {**self.body(), **({} if self.heuristic_rows == 10 else {"heuristic_rows": self.heuristic_rows})}


def check_grid_sizes(s: DCPSettings) -> tuple[int, ...]:
    """``s.grid_sizes`` checked (a :class:`~jaxdc.training.fields.SettingError` naming the fields otherwise):
    at least two distinct sizes, each a DCP grid size, ``grid_size`` among them, a network that plays every size
    and trains with A2C, and ``num_envs`` (and each minibatch) split evenly over the sizes."""
    from jaxdc.dcp.env import MAX_RANGE
    from jaxdc.nets.body import GRID_FREE_POOLS

    sizes = s.grid_sizes
    if isinstance(sizes, (str, bytes)) or not isinstance(sizes, (tuple, list)):
        raise SettingError(f"{{0}} must be a list of grid sizes, got {SettingError.text(repr(sizes))}", "grid_sizes")
    try:
        sizes = tuple(grid.check_grid_size(n, max_cells=MAX_RANGE) for n in sizes)
    except (TypeError, ValueError) as e:
        raise SettingError(f"{{0}}: {SettingError.text(e)}", "grid_sizes") from None
    shown = SettingError.text(" ".join(map(str, sizes)))
    if len(sizes) < 2 or len(set(sizes)) != len(sizes):
        raise SettingError(f"{{0}} {shown}: give at least two distinct sizes (one size is {{1}})",
                           "grid_sizes", "grid_size")
    if s.grid_size not in sizes:
        raise SettingError(f"{{0}} {shown} must include {{1}} ({s.grid_size}), the size evaluated during "
                           "training", "grid_sizes", "grid_size")
    if s.uses_q_learning:
        raise SettingError(f"{{0}} trains an actor-critic (A2C) over several grid sizes; {s.net!r} trains with "
                           "n-step Q-learning", "grid_sizes")
    if s.body_pool not in GRID_FREE_POOLS:
        raise SettingError(f"{{0}} {shown} needs a network that plays every grid size: set {{1}} to one of "
                           f"{SettingError.text(GRID_FREE_POOLS)} (the flattened body's parameters depend on the size)",
                           "grid_sizes", "body_pool")
    c, minibatches = s.config, getattr(s.config, "minibatches", 1)  # an A2CConfig here (EQN refused above)
    if c.num_envs % len(sizes) or (c.batch_size // len(sizes)) % minibatches:
        raise SettingError(f"{{0}} ({c.num_envs}) must be a multiple of the {len(sizes)} grid sizes of {{1}}, and "
                           f"{{2}} ({minibatches}) must divide each size's share of a rollout "
                           f"({{0}} x {{3}} / {len(sizes)})", "num_envs", "grid_sizes", "minibatches", "t_max")
    return sizes


def start_params(s: DCPSettings) -> tuple[Any, str] | None:
    """``(params, digest)`` that start the run of ``s`` (``None`` without ``init_from``): the parameters of the
    network ``s.init_from`` (:func:`jaxdc.dcp.learned.load`) and their SHA-256 (recorded as ``init_sha256``).

    The source must be the run's network, trained on the same grid size (unless its body pools over the cells:
    :func:`jaxdc.dcp.learned.plays_any_grid`) and observation (the shapes of its parameters); its risk map, budget
    and items may differ -- that is what a warm start is for (e.g. ``enn_general``
    fine-tuned on one map). Anything else is a ``ValueError`` naming ``init_from``."""
    if s.init_from is None:
        return None
    source = learned.load(s.init_from)
    grid_size = s.grid_size if learned.plays_any_grid(source.metadata) else source.setting()["grid_size"]
    check_same_setting(f"init_from={s.init_from!r} ({source.source})",
                       {"net": (source.net_name, s.net), "grid_size": (grid_size, s.grid_size),
                        "observation": (source.observation, s.observation),
                        "heuristic_rows": (source.heuristic_rows, s.heuristic_rows)})
    return source.params, digest(source.params)


def run_metadata(s: DCPSettings, seeds: Iterable[int], init_sha256: str | None = None) -> dict[str, Any]:
    """The run's metadata (``config.json``, checkpoints) in the current format."""
    seeds = list(seeds)
    return {
        "format": FORMAT, "net": s.net, "grid_size": s.grid_size, "total_reward": s.total_reward,
        "risk": s.risk, "energy": list(s.energy), "max_steps": s.max_steps, "min_total_reward": s.min_total_reward,
        **({"seeds": seeds} if len(seeds) > 1 else {"seed": seeds[0]}),
        "algorithm": dataclasses.asdict(s.config),
        **instance_metadata(s),
        **({} if s.item_tilt == 0.0 else {"item_tilt": s.item_tilt}),
        **({} if s.grid_sizes is None else {"grid_sizes": list(s.grid_sizes)}),
        **{k: list(v) if isinstance(v, tuple) else v for k, v in s.network_options().items()},
        **init_metadata(s.init_from, init_sha256),
    }


def settings_from_metadata(meta: object, where: str) -> tuple[DCPSettings, tuple[int, ...]]:
    """``(settings, seeds)`` of the run whose metadata (``config.json``, :func:`run_metadata`) is ``meta``: what
    retrains it. The evaluation (``eval_episodes``, ``greedy_eval``, ``eval_epsilon``) is not recorded and keeps
    its defaults. Each failure is a ``ValueError`` naming ``where`` (:func:`jaxdc.metadata.check_run`)."""
    meta = check_run(meta, "dcp", where)
    energy = recorded_pair(meta.get("energy", list(DCPSettings.energy)), "energy", where, " [initial, maximum]")
    setting = {k: meta[k] for k in ("risk", "grid_size", "total_reward", "min_total_reward", "max_steps",
                                    "observation", "risk_maps", "init_fraction", "init_from", "energy_tilt",
                                    "item_tilt", "heuristic_rows",
                                    *learned.BODY_KEYS)  # the body's list is checked by DCPSettings
               if meta.get(k) is not None}
    for k in ("map_seeds", "energy_range"):  # pairs, stored as lists
        if meta.get(k) is not None:
            setting[k] = recorded_pair(meta[k], k, where)
    if meta.get("grid_sizes") is not None:  # a list; DCPSettings checks its entries
        sizes = meta["grid_sizes"]
        if not isinstance(sizes, list):
            raise ValueError(f"{where}: key 'grid_sizes': must be a list of grid sizes, got {sizes!r}")
        setting["grid_sizes"] = tuple(sizes)
    return run_settings(DCPSettings, meta, where, energy=energy, **setting)


class DCPRun(TrainingRun):
    """A DCP training run: its network, environment and heuristics, and the loop of :class:`TrainingRun`."""

    def __init__(self, settings: DCPSettings, control: RunControl) -> None:
        s = self.settings = settings
        start = start_params(s)  # the source is read before any work
        init_params, sha = (None, None) if start is None else start
        meta = run_metadata(s, control.seeds, sha)
        self.claim(control, meta)  # lock the folder, check a resume: before the build
        algo = nstep_q if s.uses_q_learning else a2c
        self.net = learned.make_network(s.net, s.network_options())
        def training_env(n: int) -> dcp_env.DCP:  # the run's training environment on an n x n grid
            return dcp_env.DCP(grid_size=n, total_reward=s.total_reward, min_total_reward=s.min_total_reward,
                               observation=s.observation, item_tilt=s.item_tilt)

        self.env = training_env(s.grid_size)
        extra: list[a2c.EnvGroup] = []
        if s.per_episode:
            self.env_params = training_params(s, self.env)
            check_batch_fits(s.config, self.env, self.env_params, len(control.seeds))
            self.heuristics = instances.batched_heuristics(self.env_params, rows=s.heuristic_rows)
        else:
            self.env_params = self.env.make_params(s.risk, tuple(s.energy), s.max_steps)
            check_batch_fits(s.config, self.env, self.env_params, len(control.seeds))
            table = jax.jit(safest_paths)(self.env_params.risk)  # once per run: the risk map is fixed
            self.heuristics = navigators.batched_heuristics(self.env_params, table, rows=s.heuristic_rows)
        for n in [] if s.grid_sizes is None else [n for n in s.grid_sizes if n != s.grid_size]:
            env = training_env(n)
            params = training_params(s, env)  # the maps of the generator (or the preset) drawn at this size
            check_batch_fits(s.config, env, params, len(control.seeds))  # each size as if it had every env
            extra.append(a2c.EnvGroup(env, params, instances.batched_heuristics(params, rows=s.heuristic_rows)))
        warm = {} if init_params is None else {"init_params": init_params}
        if extra:
            warm["extra_envs"] = tuple(extra)
        trainer, mesh = spread(algo.make_train(s.config, self.env, self.env_params, self.net, self.heuristics,
                                               **warm), control, s.config.num_envs, 1 + len(extra))
        eval_env = dcp_env.DCP(grid_size=s.grid_size, total_reward=s.total_reward, observation=s.observation)

        def episodes(params, key):
            return run_episodes(eval_env, self.env_params, self.policy(params), key, s.eval_episodes)

        self._episodes = jax.jit(jax.vmap(episodes) if control.multi else episodes)
        super().__init__(control, RunSpec(s.config, trainer, mesh, meta, self.evaluate,
                                          LOSS_METRICS, CSV_FIELDS))
        check_evaluation_fits(self, self._episodes)

    def policy(self, params: Any) -> Callable:
        """The evaluation policy: sampled from pi (argmax if ``greedy_eval``); EQN: epsilon-greedy."""
        s = self.settings
        if s.uses_q_learning:
            return nstep_q.make_q_policy(self.net, params, self.heuristics,
                                         epsilon=0.0 if s.greedy_eval else s.eval_epsilon)
        return a2c.make_policy(self.net, params, self.heuristics, greedy=s.greedy_eval)

    def evaluate(self, params: Any, key: jax.Array) -> list[dict]:
        """Evaluation columns of each seed."""
        results = jax.device_get(self._episodes(params, key))
        rows = []
        for i in range(len(self.seeds)):
            # the lambda runs at once (tree_map), with this iteration's i
            r = summarize(jax.tree_util.tree_map(lambda x: x[i], results) if self.multi else results)  # noqa: B023
            rows.append({"eval_reward": r["reward"]["mean"], "eval_reward_sd": r["reward"]["sd"],
                         "eval_energy": r["energy"]["mean"], "eval_rpe": r["rpe"]["mean"]})
        return rows
