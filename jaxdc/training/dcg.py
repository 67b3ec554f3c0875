"""A DCG training run: VNN, IMNN, EMNN, OMN + CoNN (section 5.4) with synchronous A2C (Algorithms 10-12).

Losses: VNN and IMNN the A2C loss (section 5.4.2); EMNN adds ``alpha`` times
the cross-entropy of Eq. 5.1 (Algorithm 11); OMN + CoNN adds OMN's
cross-entropy with weight 1, which trains OMN alone (Algorithm 12;
:mod:`jaxdc.nets.omn_conn`). :class:`DCGSettings` holds the problem's side of
a run; :class:`DCGRun` builds the game, the trainer, the metadata and the
evaluation (episode statistics and, for the networks with an opponent head,
:func:`opponent_accuracy`), runs them with the loop of
:class:`~jaxdc.training.loop.TrainingRun`, and :meth:`DCGRun.ship` writes the
final parameters as a parameter file.

With ``collectors = k > 1`` (beyond the thesis: the team game its conclusion to chapter 5 proposes) the run
trains one network shared by the ``k`` collectors of :class:`jaxdc.dcg.team.DCGTeam` on the team reward
(independent actor-critic with parameter sharing, IPPO with the PPO-style options: :mod:`jaxdc.agents.a2c`),
each collector seeing the teammates plane; the evaluation plays the team (the team reward per game) and the
opponent-action accuracy is scored per collector against the first opponent's action. ``algo="mappo"`` trains the
same way with a centralised critic on the team's world state (MAPPO, Yu et al. 2022; issue 29:
:mod:`jaxdc.agents.centralised`, :class:`jaxdc.nets.critic.WorldCritic`); the critic is only for training, so
:meth:`DCGRun.ship` writes the actor alone.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterable
from typing import Any

import jax
import jax.numpy as jnp

from jaxdc import pretrained
from jaxdc.agents import a2c
from jaxdc.agents.centralised import actor_params
from jaxdc.core.batched import reset_batched
from jaxdc.core.energy import check_energy_range
from jaxdc.core.env import step_batch
from jaxdc.core.masks import MASKS, make_mask
from jaxdc.core.rollout import run_episodes
from jaxdc.core.stats import episode_summary
from jaxdc.core.tree_check import digest
from jaxdc.core.validate import check_choice, check_int
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.env import DCG, MIN_RANGE_ENERGY, OBSERVATIONS, OUTCOMES
from jaxdc.dcg.learned import opponent_labels
from jaxdc.dcg.opponents import STANDARD_STRATEGIES
from jaxdc.dcg.team import DCGTeam
from jaxdc.dcg.team.observation import TEAMMATES_PLANE
from jaxdc.dcg.team.policies import copies
from jaxdc.dcg.team.state import MAX_COLLECTORS
from jaxdc.metadata import FORMAT, check_run, recorded_pair, run_settings
from jaxdc.nets import DCG_NETS, build
from jaxdc.nets.registry import ALGOS, build_critic
from jaxdc.nets.transfer import widen_inputs
from jaxdc.training.fields import SettingError, check_tilt_has_range
from jaxdc.training.loop import RunControl, RunSpec, TrainingRun, check_batch_fits, check_evaluation_fits, spread
from jaxdc.training.warm_start import check_init_from, check_same_setting, init_metadata

#: The networks a DCG run trains (the names of the registry :data:`jaxdc.nets.registry.DCG_NETS`).
NETS = tuple(DCG_NETS)
LOSS_METRICS = ("loss", "policy_loss", "value_loss", "entropy", "aux_loss", "aux_accuracy")
CSV_FIELDS = ("env_steps", "updates", "wall_s", "steps_per_s", "lr", *LOSS_METRICS, "train_episodes",
              "train_reward", "eval_reward", "eval_reward_sd", "eval_rpe", "eval_opponent_accuracy")
#: Rollout of the opponent-accuracy evaluation: environments x steps.
ACCURACY_ENVS, ACCURACY_STEPS = 64, 64


@dataclasses.dataclass(frozen=True)
class DCGSettings:
    """The problem's side of a DCG run (defaults: section 5.5.1).

    Attributes:
      net: one of :data:`NETS`.
      config: the ``A2CConfig`` (its ``aux_coef``: EMNN's ``alpha``, 1 for OMN + CoNN).
      alpha: EMNN's weight of Eq. 5.1 as given (recorded in the metadata; ``None`` for the other networks).
      energy, grid_size, total_reward, strategies, history, max_steps: the game (``total_reward=None``: the
        game's default).
      reward_area, min_reward_area: the one-item game of section 5.5.5 (beyond the thesis as a training game).
      eval_episodes, greedy_eval: the evaluation.
      observation: ``"thesis"`` or ``"general"`` (:data:`jaxdc.dcg.env.OBSERVATIONS`: the budget plane and scaled
        energies; beyond the thesis, docs/generalisation.md).
      energy_range: ``None`` (every episode has ``energy``) or ``(low, high)``: each training and evaluation
        episode draws its maximum energy among the integers of the range (beyond the thesis); ``energy`` is then
        only recorded.
      energy_tilt: with ``energy_range``, 0 (uniform) or a power-law tilt of the draw
        (:func:`jaxdc.core.energy.draw_max_energy`; a positive tilt weights the low budgets; beyond the thesis).
      collectors: ``k``, 1 (the thesis' game) .. :data:`~jaxdc.dcg.team.state.MAX_COLLECTORS`; with ``k > 1`` the
        team game (module docs; beyond the thesis).
      init_from: ``None`` (a fresh initialisation, as the thesis) or a trained network of the same kind -- a
        shipped name, a ``.msgpack`` or a ``train.dcg`` run folder -- whose parameters start the run (a warm
        start, beyond the thesis: :func:`start_params`).
      algo: the team learner, one of :data:`~jaxdc.nets.registry.ALGOS`: ``"ippo"`` (default; each collector's
        value on its own observation) or ``"mappo"`` (a centralised critic on the world state; ``collectors >= 2``
        only). Beyond the thesis (issue 29).
      mask: an action mask of :data:`jaxdc.core.masks.MASKS` the collector trains (and is evaluated) under:
        ``"none"`` (default, the thesis' policy), ``"reach_base"`` or ``"reach_base_or_item"`` (beyond the thesis;
        one collector only).
    """

    net: str
    config: a2c.A2CConfig
    alpha: float | None = None
    energy: float = 15.0
    grid_size: int = 5
    total_reward: int | None = None
    strategies: tuple[str, ...] = tuple(STANDARD_STRATEGIES)
    history: int = 10
    max_steps: int = 100
    reward_area: int | None = None
    min_reward_area: int | None = None
    eval_episodes: int = 500
    greedy_eval: bool = False
    observation: str = "thesis"
    energy_range: tuple[float, float] | None = None
    energy_tilt: float = 0.0
    collectors: int = 1
    init_from: str | None = None
    algo: str = "ippo"
    mask: str = "none"

    def __post_init__(self) -> None:
        check_choice("observation", self.observation, OBSERVATIONS)
        check_int("collectors", self.collectors, 1, MAX_COLLECTORS)
        check_choice("algo", self.algo, tuple(ALGOS))
        if self.algo != "ippo" and self.collectors < 2:
            raise SettingError(f"{{0}} {SettingError.text(repr(self.algo))} (a centralised critic on a team's world "
                               f"state) needs {{1}} >= 2, got {self.collectors}; with one collector {{0}} must be "
                               f"'ippo' (the allowed values: {SettingError.text(tuple(ALGOS))})", "algo", "collectors")
        check_init_from(self.init_from)
        check_choice("mask", self.mask, MASKS)
        if self.mask != "none" and self.collectors > 1:
            raise SettingError(f"{{0}} {SettingError.text(repr(self.mask))} plays one collector's state; with "
                               f"{{1}} = {self.collectors} it must be 'none'", "mask", "collectors")
        if self.energy_range is not None:
            check_energy_range(self.energy_range, MIN_RANGE_ENERGY)
        check_tilt_has_range(self.energy_tilt, self.energy_range)

    @property
    def has_aux(self) -> bool:
        """Whether the network has the opponent-action head (the registry's ``has_aux``: EMNN, OMN + CoNN)."""
        return DCG_NETS[self.net].has_aux


def opponent_accuracy(env: DCG | DCGTeam, env_params: Any, net: Any, params: Any, key: jax.Array,
                      num_envs: int = ACCURACY_ENVS, steps: int = ACCURACY_STEPS) -> jax.Array:
    """Share of steps on which the argmax of the opponent-action head equals ``o_t`` (section 5.5.3).

    ``num_envs`` games played for ``steps`` steps with the stochastic policy (auto-reset); the
    prediction at ``(s_t, h_t)`` is scored against the opponent's next action ``o_t``, the label
    of Eq. 5.1.
    """
    k_reset, k_run = jax.random.split(key)
    obs, state = reset_batched(env, k_reset, num_envs, env_params)
    k = env.collectors if isinstance(env, DCGTeam) else 1
    team = isinstance(env, DCGTeam)

    def step(carry, k_step):
        obs, state = carry
        k_act, k_env = jax.random.split(k_step)
        logits, _, opp_logits = net.apply(params, obs.reshape((-1,) + obs.shape[-3:]) if team else obs)
        action = jax.random.categorical(k_act, logits).astype(jnp.int32)
        obs2, state2, *_, info = step_batch(env, k_env, state, action.reshape(-1, k) if team else action,
                                            env_params)
        # a team: each collector's prediction against the first opponent's action
        label = jnp.repeat(info["opponent_action"][:, 0], k) if team else info["opponent_action"]
        return (obs2, state2), jnp.mean(jnp.argmax(opp_logits, -1) == label)

    _, hits = jax.lax.scan(step, (obs, state), jax.random.split(k_run, steps))
    return jnp.mean(hits)


def make_game(s: DCGSettings) -> DCG | DCGTeam:
    """The DCG of the run (the team game with ``collectors > 1``; VNN's needs no history planes). Its construction
    validates the game's options (strategies, reward area, ...) and starts no JAX computation, so a command line
    checks them with it before ``jax.distributed`` is initialised."""
    history_net = s.net != "vnn"
    options: dict[str, Any] = dict(grid_size=s.grid_size, total_reward=s.total_reward,
                                   strategies=",".join(s.strategies),
                                   history=s.history if history_net else 1, obs_history=history_net,
                                   reward_area=s.reward_area, min_reward_area=s.min_reward_area,
                                   observation=s.observation)
    return DCG(**options) if s.collectors == 1 else DCGTeam(collectors=s.collectors, **options)


def make_env(s: DCGSettings) -> tuple[DCG | DCGTeam, Any]:
    """The DCG of the run (:func:`make_game`) and its params."""
    env = make_game(s)
    return env, env.make_params(energy=s.energy, max_steps=s.max_steps, energy_range=s.energy_range,
                                energy_tilt=s.energy_tilt)


def start_params(s: DCGSettings, env: DCG | DCGTeam, env_params: Any, net: Any) -> tuple[Any, str] | None:
    """``(params, digest)`` that start the run of ``s`` (``None`` without ``init_from``): the parameters of the
    network ``s.init_from`` (:func:`jaxdc.dcg.learned.load`), and their SHA-256 (:func:`jaxdc.core.tree_check.digest`,
    recorded as ``init_sha256``).

    The source must be the run's network, trained on the same grid, history and observation, by one collector or
    by a team of the run's size. A one-collector network starting a team gets zero weights on the teammates plane
    (:func:`jaxdc.nets.transfer.widen_inputs` at :data:`~jaxdc.dcg.team.observation.TEAMMATES_PLANE`): the team
    starts as copies of it (:func:`jaxdc.dcg.team.policies.copies`). Anything else is a ``ValueError`` naming
    ``init_from``."""
    if s.init_from is None:
        return None
    source = learned_lib.load(s.init_from)
    where = f"init_from={s.init_from!r} ({source.source})"
    trained = source.setting()
    history = trained["history"] if s.net != "vnn" else s.history
    ours = {"net": (source.net_name, s.net), "grid_size": (trained["grid_size"], s.grid_size),
            "history": (history, s.history),
            "observation": (source.metadata.get("observation", "thesis"), s.observation)}
    check_same_setting(where, ours)
    if source.collectors not in (1, s.collectors):
        raise ValueError(f"{where}: trained by a team of {source.collectors} collectors; it starts a run of one "
                         f"collector or of {source.collectors}, not of {s.collectors}")
    obs = jnp.zeros((1,) + tuple(env.observation_shape(env_params)[-3:]), jnp.float32)
    template = jax.eval_shape(net.init, jax.random.PRNGKey(0), obs, jnp.zeros((1, 1, net.num_actions), jnp.float32))
    extra = env.state_channels - learned_lib.state_channels(source.metadata)
    params = widen_inputs(source.params, template, TEAMMATES_PLANE, extra, where)
    return params, digest(params)


def run_metadata(s: DCGSettings, env: DCG | DCGTeam, seeds: Iterable[int],
                 init_sha256: str | None = None) -> dict[str, Any]:
    """The run's metadata (``config.json``, checkpoints) in the current format."""
    seeds = list(seeds)
    return {
        "format": FORMAT, "net": s.net, "problem": "dcg", "grid_size": s.grid_size,
        "total_reward": env.total_reward, "strategies": list(env.strategies), "energy": s.energy,
        "max_steps": s.max_steps, "history": s.history if s.net != "vnn" else 0,
        "alpha": s.alpha if s.net == "emnn" else None,
        "reward_area": s.reward_area, "min_reward_area": s.min_reward_area,
        **({"seeds": seeds} if len(seeds) > 1 else {"seed": seeds[0]}),
        "algorithm": dataclasses.asdict(s.config),
        # beyond the thesis, written only when set (the thesis' runs' files are unchanged)
        **({} if s.observation == "thesis" else {"observation": s.observation}),
        **({} if s.energy_range is None else {"energy_range": list(s.energy_range)}),
        **({} if s.energy_tilt == 0.0 else {"energy_tilt": s.energy_tilt}),
        **({} if s.collectors == 1 else {"collectors": s.collectors}),
        **({} if s.algo == "ippo" else {"algo": s.algo}),
        **({} if s.mask == "none" else {"mask": s.mask}),
        **init_metadata(s.init_from, init_sha256),
    }


def settings_from_metadata(meta: object, where: str) -> tuple[DCGSettings, tuple[int, ...]]:
    """``(settings, seeds)`` of the run whose metadata (``config.json``, :func:`run_metadata`) is ``meta``: what
    retrains it. The evaluation (``eval_episodes``, ``greedy_eval``) is not recorded and keeps its defaults; VNN's
    recorded ``history`` 0 (no history planes) is the default ``k``. Each failure is a ``ValueError`` naming
    ``where`` (:func:`jaxdc.metadata.check_run`)."""
    meta = check_run(meta, "dcg", where)
    setting = {k: meta[k] for k in ("alpha", "energy", "grid_size", "total_reward", "max_steps", "reward_area",
                                    "min_reward_area", "observation", "energy_tilt", "collectors", "init_from", "algo",
                                    "mask")
               if meta.get(k) is not None}
    if meta.get("energy_range") is not None:
        setting["energy_range"] = recorded_pair(meta["energy_range"], "energy_range", where, " [low, high]")
    if meta.get("history"):
        setting["history"] = meta["history"]
    if "strategies" in meta:
        strategies = meta["strategies"]
        if not isinstance(strategies, list) or not all(isinstance(x, str) for x in strategies):
            raise ValueError(f"{where}: strategies={strategies!r} must be a list of strategy names")
        setting["strategies"] = tuple(strategies)
    return run_settings(DCGSettings, meta, where, **setting)


class DCGRun(TrainingRun):
    """A DCG training run: its network and game, and the loop of :class:`TrainingRun`."""

    def __init__(self, settings: DCGSettings, control: RunControl) -> None:
        s = self.settings = settings
        self.env, self.env_params = make_env(s)  # validates grid, strategies, energy
        self.net = build("dcg", s.net, history=s.history, state_channels=self.env.state_channels)  # validates k
        if s.config.aux_lr is not None and s.net != "omn_conn":
            raise SettingError(f"{{0}} sets OMN's learning rate and applies to {{1}} omn_conn only, not "
                               f"{SettingError.text(repr(s.net))}", "aux_lr", "net")
        start = start_params(s, self.env, self.env_params, self.net)  # the source is read before any work
        init_params, sha = (None, None) if start is None else start
        meta = run_metadata(s, self.env, control.seeds, sha)
        self.claim(control, meta)  # lock, check a resume: before the build
        check_batch_fits(s.config, self.env, self.env_params, len(control.seeds))
        aux = s.has_aux
        k = s.collectors
        trainer, mesh = spread(a2c.make_train(s.config, self.env, self.env_params, self.net,
                                              aux_target=opponent_labels(k) if aux else None,
                                              init_params=init_params, critic=build_critic(s.algo),
                                              mask=make_mask(s.mask, s.grid_size)),
                               control, s.config.num_envs)

        def evaluate(params, key):
            k_ep, k_acc = jax.random.split(key)
            policy = a2c.make_policy(self.net, params, greedy=s.greedy_eval, mask=make_mask(s.mask, s.grid_size))
            if k > 1:  # the one network from each collector's seat
                policy = copies(policy, k)
            finals = run_episodes(self.env, self.env_params, policy, k_ep, s.eval_episodes)
            acc = opponent_accuracy(self.env, self.env_params, self.net, params, k_acc) if aux else jnp.nan
            return finals, acc

        self._evaluate = jax.jit(jax.vmap(evaluate) if control.multi else evaluate)
        super().__init__(control, RunSpec(s.config, trainer, mesh, meta,
                                          self.evaluate, LOSS_METRICS, CSV_FIELDS))
        check_evaluation_fits(self, self._evaluate)

    def evaluate(self, params: Any, key: jax.Array) -> list[dict]:
        """Evaluation columns of each seed."""
        finals, acc = jax.device_get(self._evaluate(params, key))
        rows = []
        for i in range(len(self.seeds)):
            # the lambda runs at once (tree_map), with this iteration's i
            r = episode_summary(jax.tree_util.tree_map(lambda x: x[i], finals) if self.multi else finals,  # noqa: B023
                                OUTCOMES)
            row = {"eval_reward": r["reward"]["mean"], "eval_reward_sd": r["reward"]["sd"],
                   "eval_rpe": r["rpe"]["mean"]}
            if self.settings.has_aux:
                row["eval_opponent_accuracy"] = float(acc[i] if self.multi else acc)
            rows.append(row)
        return rows

    def ship(self, path: str, command: str) -> str:
        """Write the final parameters and their metadata (:func:`jaxdc.pretrained.save`); ``path`` empty:
        ``jaxdc/assets/dcg/NET.msgpack``. A MAPPO run writes its actor alone (the network that plays)."""
        path = path or os.path.join(pretrained.ASSETS, "dcg", f"{self.settings.net}.msgpack")
        meta = {k: v for k, v in self.metadata.items() if k not in ("format", "algorithm")}
        meta.update(steps=self.config.total_steps, obs_history=self.env.obs_history, command=command,
                    algorithm=dataclasses.asdict(self.config))
        return pretrained.save(path, actor_params(self.final_state.params), meta)  # the critic only trains
