"""Trained DCG collectors (section 5.4): load their parameters and rebuild the game they were trained in.

A trained network comes from one of three places:

* a **shipped** parameter file ``jaxdc/assets/dcg/<name>.msgpack``
  (:func:`shipped`, :func:`shipped_names`);
* an **exported** parameter file written by :func:`jaxdc.pretrained.save`;
* a **run folder** of ``python -m train.dcg`` (its latest orbax checkpoint).

:func:`load` returns a :class:`Learned`: the network (VNN, IMNN, EMNN or
OMN + CoNN, :func:`jaxdc.nets.make_dcg_net`), its parameters and the metadata
of its training, whatever the source. Every source is checked: a missing or
damaged file, another problem, an unknown network, or parameters whose
shapes do not fit the network (another grid size or history length), or
parameters holding NaN or infinity, raise a ``ValueError`` that names the file
and the problem. :meth:`Learned.game` rebuilds the DCG
of training, with optional changes (energy, strategy set, reward area, ...); a network trained by a team
(``collectors`` in its metadata, ``train.dcg --collectors K``) gets the team game
(:class:`jaxdc.dcg.team.DCGTeam`), and :meth:`Learned.policy` is then one collector's policy, which
:func:`jaxdc.dcg.team.policies.copies` turns into the team's. A team trained with a centralised critic
(``algo: "mappo"``, ``train.dcg --algo mappo``; beyond the thesis, issue 29) loads as its actor alone: a run
folder's critic parameters (and any a parameter file holds) are dropped
(:func:`jaxdc.agents.centralised.actor_params`), since only the actor plays.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from jaxdc import pretrained
from jaxdc.core.tree_check import check_like
from jaxdc.dcg.env import DCG
from jaxdc.dcg.opponents import STANDARD_STRATEGIES
from jaxdc.dcg.team import DCGTeam
from jaxdc.dcg.team.state import MAX_COLLECTORS
from jaxdc.nets.registry import ALGOS, DCG_NETS, build, build_critic

#: Networks of section 5.4, in the order of the thesis' figures (the registry :data:`jaxdc.nets.registry.DCG_NETS`).
NETS = tuple(DCG_NETS)
#: The standard setting of section 5.5.1 (and ``train.dcg``'s defaults) for metadata that lacks a key.
DEFAULT_SETTING = {"grid_size": 5, "total_reward": 10, "energy": 15.0, "max_steps": 100,
                   "strategies": list(STANDARD_STRATEGIES), "history": 10, "chase_tie": "straight"}
#: ``DCG(...)`` options that change the dynamics, taken from the metadata (``"env"`` or top level) when present.
ENV_OPTION_KEYS = ("history_fill", "items_on_base", "opponent_start", "patrol_target", "reward_when_caught",
                   "energy_metric", "reward_area", "min_reward_area", "observation")


def _strategies(name: str, value: Any) -> Any:
    """A stored strategy set: a list of names (or the comma-separated text of ``--strategies``)."""
    from jaxdc.dcg.opponents import get_strategies

    if not isinstance(value, (str, list)) or not all(isinstance(v, str) for v in value):
        raise TypeError(f"{name} must be a list of strategy names, got {value!r}")
    try:
        get_strategies(value)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: {e}") from None
    return value


def _energy_range(name: str, value: Any) -> tuple[float, float]:
    """A stored range of maximum energies: a JSON pair ``[low, high]``
    (:func:`jaxdc.core.energy.check_energy_range`)."""
    from jaxdc.core.energy import check_energy_range

    if not isinstance(value, list):
        raise TypeError(f"{name} must be a pair [low, high], got {value!r}")
    return check_energy_range(value, 1.0, name)


def _setting_schema() -> dict[str, pretrained.SettingCheck]:
    """The checks of a DCG network's stored setting: those of ``train.dcg``'s and ``eval.dcg``'s flags (the
    constructor's choices and ranges), strict about JSON types."""
    from jaxdc.core.energy import ENERGY_METRICS, MAX_ENERGY_TILT, MAX_FINITE_ENERGY
    from jaxdc.core.masks import MASKS
    from jaxdc.core.sampling import MAX_TOTAL_REWARD
    from jaxdc.core.validate import SEED_MAX
    from jaxdc.dcg import env as dcg_env
    from jaxdc.dcg.opponents import CHASE_TIES
    from jaxdc.pretrained import json_bool, json_choice, json_int, json_number, json_object, json_string, optional

    options = {"history_fill": json_choice(dcg_env.HISTORY_FILLS), "items_on_base": json_bool,
               "opponent_start": json_choice(dcg_env.OPPONENT_STARTS),
               "patrol_target": json_choice(dcg_env.PATROL_TARGETS), "reward_when_caught": json_bool,
               "energy_metric": json_choice(ENERGY_METRICS), "reward_area": optional(json_int(1)),
               "min_reward_area": optional(json_int(1)), "observation": json_choice(dcg_env.OBSERVATIONS)}
    return {
        "grid_size": json_int(2), "total_reward": json_int(1, MAX_TOTAL_REWARD),
        "energy": json_number(0.0, MAX_FINITE_ENERGY, low_open=True), "max_steps": json_int(1),  # trained: finite
        "strategies": _strategies, "history": json_int(0), "chase_tie": json_choice(CHASE_TIES),
        "obs_history": json_bool, "alpha": optional(json_number(0.0)), "seed": json_int(0, SEED_MAX),
        "steps": json_int(1, None), "updates": json_int(1, None), "energy_range": optional(_energy_range),
        "energy_tilt": json_number(-MAX_ENERGY_TILT, MAX_ENERGY_TILT),
        "collectors": json_int(1, MAX_COLLECTORS), "init_from": optional(json_string),
        "init_sha256": optional(json_string), "algo": json_choice(tuple(ALGOS)), "mask": json_choice(MASKS),
        **options, "env": json_object(options),
    }


def check_setting(meta: dict, where: str) -> dict:
    """``meta`` if its stored setting passes the checks of the flags (:func:`_setting_schema`), its history
    planes fit in memory and it builds the game of training; else a ``ValueError`` (``MemoryError``) naming
    ``where`` (the file) and the key."""
    from jaxdc.core import memory

    pretrained.check_settings(meta, where, _setting_schema())
    n = meta.get("grid_size", DEFAULT_SETTING["grid_size"])
    k = meta.get("history", DEFAULT_SETTING["history"])
    # the network reads [N, N, 2 + k] planes and each game keeps [N, N, k]: the least an evaluation holds
    memory.check_fits(2 * 4 * n * n * (2 + k), f"{where}: key 'history': {k} history planes of {n}x{n}",
                      "the history (retrain with a smaller --history)")
    try:
        Learned(str(meta.get("net")), None, None, meta, where).game()
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: its setting does not build the game: {e}") from None
    return meta


def state_channels(meta: dict) -> int:
    """The state planes of the observation the network of ``meta`` was trained on: 2, plus the budget plane of
    the ``"general"`` observation, plus the teammates plane of a team (``collectors > 1``; beyond the thesis)."""
    general = meta.get("observation", meta.get("env", {}).get("observation")) == "general"
    return 2 + int(general) + int(meta.get("collectors", 1) > 1)


def opponent_labels(collectors: int) -> Callable:
    """``info -> labels`` of the opponent-action head (Eq. 5.1): ``info["opponent_action"]`` ``[B]``; for a team of
    ``collectors > 1``, the first opponent's action for every collector, ``[B, k]``."""
    if collectors == 1:
        return lambda info: info["opponent_action"]
    return lambda info: jnp.repeat(info["opponent_action"][:, :1], collectors, axis=1)


def make_network(name: str, history: int = 10, planes: int = 2) -> Any:
    """The flax module of ``name`` (:data:`NETS`) for a history of ``k = history`` planes after ``planes`` state
    planes."""
    return build("dcg", name, history=history, state_channels=planes)


def init_params(net: Any, grid_size: int, history: int, key: jax.Array | None = None, planes: int = 2) -> Any:
    """Fresh parameters of ``net`` for observations ``[1, N, N, planes + k]`` (``k = 0``: no history, VNN)."""
    obs = jnp.zeros((1, grid_size, grid_size, planes + history), jnp.float32)
    return net.init(key if key is not None else jax.random.PRNGKey(0), obs, jnp.zeros((1, 1, 9), jnp.float32))


@dataclasses.dataclass(frozen=True)
class Learned(pretrained.Learned):
    """A trained DCG network with its parameters and the metadata of its training."""

    def setting(self) -> dict:
        """The setting of training: ``grid_size, total_reward, energy, max_steps, strategies, history, chase_tie``."""
        out = {}
        for k, default in DEFAULT_SETTING.items():
            v = self.metadata.get(k, self.metadata.get("env", {}).get(k, default))
            out[k] = v
        out["strategies"] = list(out["strategies"]) if not isinstance(out["strategies"], str) \
            else out["strategies"].split(",")
        return out

    @property
    def steps(self) -> int | None:
        """Training steps (``T_max``), from the metadata; ``None`` if not recorded."""
        return self.metadata.get("steps", self.metadata.get("algorithm", {}).get("total_steps"))

    @property
    def collectors(self) -> int:
        """The collectors of training: 1 (the thesis' game), or a team's ``k`` (``train.dcg --collectors``)."""
        return int(self.metadata.get("collectors", 1))

    @property
    def has_aux(self) -> bool:
        """Whether the network predicts the opponent's action (EMNN, OMN + CoNN)."""
        return bool(getattr(self.net, "has_aux", False))

    def env_options(self) -> dict:
        """The ``DCG(...)`` options of training that change the dynamics (:data:`ENV_OPTION_KEYS`; only those
        recorded, in the metadata's ``"env"`` or at its top level)."""
        meta_env = self.metadata.get("env", {})
        options = {k: meta_env.get(k, self.metadata.get(k)) for k in ENV_OPTION_KEYS}
        return {k: v for k, v in options.items() if v is not None}

    def game(self, energy: float | None = None, strategies: Any = None, reward_area: int | None = None,
             max_steps: int | None = None) -> tuple[DCG | DCGTeam, Any]:
        """``(env, params)``: the DCG of training, with the given settings changed.

        A network trained over a range of maximum energies (``energy_range`` in its metadata) plays that range,
        each integer equally likely (a training ``energy_tilt`` is not the game it is judged on), unless ``energy``
        fixes one. ``reward_area`` (Figs. 5.10-5.12) places one unit item uniformly in the
        bottom-right ``s x s`` square. The initial states depend only on the
        key, not on the network, so two networks evaluated with the same key
        play the same games.
        """
        s = self.setting()
        options = self.env_options()
        if reward_area is not None:  # one size: the game of that figure, not the training mix
            options["reward_area"] = reward_area
            options.pop("min_reward_area", None)
        # train.dcg plays VNN without history planes (metadata history 0); VNN reads obs[..., :2] either way
        k = int(s["history"])
        obs_history = bool(self.metadata.get("obs_history", k > 0))
        game = DCG if self.collectors == 1 else functools.partial(DCGTeam, collectors=self.collectors)
        env = game(grid_size=s["grid_size"], total_reward=1 if reward_area is not None else s["total_reward"],
                   strategies=tuple(strategies if strategies is not None else s["strategies"]),
                   history=max(k, 1), obs_history=obs_history, **options)
        energy_range = self.metadata.get("energy_range") if energy is None else None
        params = env.make_params(energy=s["energy"] if energy is None else energy,
                                 max_steps=s["max_steps"] if max_steps is None else max_steps,
                                 chase_tie=s["chase_tie"], energy_range=energy_range)
        return env, params

    @property
    def mask(self) -> str:
        """The action mask the network was trained under (``train.dcg --mask``; ``"none"``, the thesis' policy)."""
        return str(self.metadata.get("mask", "none"))

    def policy(self, greedy: bool = False, mask: str | None = None) -> Callable:
        """``policy(key, obs, state) -> action``: samples from ``pi`` (section 5.5.1: "The collector's policy is
        stochastic"), or takes its argmax if ``greedy`` (the deterministic policy of Figs. 5.13-5.15).

        ``mask``: one of :data:`jaxdc.core.masks.MASKS` (beyond the thesis; ``"none"``, the thesis' policy): the
        collector plays among the actions that leave its energy the way home (``"reach_base"``) or to an item
        (``"reach_base_or_item"``); one collector's state only. ``None``: the mask it was trained under
        (:attr:`mask`)."""
        from jaxdc.agents import a2c
        from jaxdc.core.masks import make_mask

        return a2c.make_policy(self.net, self.params, None, greedy=greedy,
                               mask=make_mask(self.mask if mask is None else mask, int(self.setting()["grid_size"])))

    def describe(self) -> str:
        """One line: network, training setting and source."""
        s = self.setting()
        alpha = self.metadata.get("alpha")
        return (f"{self.net_name}{f' (alpha {alpha:g})' if self.net_name == 'emnn' and alpha is not None else ''} "
                f"trained on {s['grid_size']}x{s['grid_size']}, {s['total_reward']} rewards"
                + (f" in the bottom-right {area}x{area} square" if (area := self.metadata.get("reward_area")) else "")
                + (f" (sizes {m}-{area})" if (m := self.metadata.get("min_reward_area")) else "")
                + (f", energy {float(s['energy']):g}, " if not (r := self.metadata.get("energy_range")) else
                   f", energies {r[0]:g}-{r[1]:g} ({self.metadata.get('observation', 'thesis')} observation), ")
                + f"strategies {','.join(s['strategies'])}, history {s['history']}, "
                + (f"a team of {self.collectors} collectors, " if self.collectors > 1 else "")
                + (f"{algo}, " if (algo := self.metadata.get("algo", "ippo")) != "ippo" else "")
                + (f"under the mask {self.mask}, " if self.mask != "none" else "")
                + f"{self.steps or '?'} steps, seed {self.metadata.get('seed', '?')} ({self.source})")


def _check(name, net, params, meta, source):
    n = meta.get("grid_size", DEFAULT_SETTING["grid_size"])
    k = meta.get("history", DEFAULT_SETTING["history"])
    planes = state_channels(meta)
    what = f"a {name} network with history k={k} on a {n}x{n} grid" + (
        "" if planes == 2 else " reading the general observation")
    return check_like(init_params(net, n, k, planes=planes), params, source, what,
                      "was it trained on another grid size or history length?")


def load(path: pretrained.PathLike, net: str | None = None, run_seed: int | None = None) -> Learned:
    """Load a trained DCG network from a parameter file (``.msgpack``) or a ``train.dcg`` run folder.

    ``net``, when given, must be the stored network's name (else ``ValueError``;
    :func:`jaxdc.pretrained.load_trained`). ``run_seed`` picks one seed of a ``train.dcg --seeds`` run
    folder (such a folder without it is refused, naming its seeds). Parameters holding NaN or infinity are
    refused (:func:`jaxdc.pretrained.check_finite`).
    """
    def target(name: str, meta: dict, source: str) -> Any:
        return train_state_template(make_network(name, meta.get("history", DEFAULT_SETTING["history"]),
                                                 state_channels(meta)), meta, source)

    from jaxdc.agents.centralised import actor_params

    name, params, meta, source = pretrained.load_trained(path, "dcg", NETS, target, net, run_seed=run_seed,
                                                         check_setting=check_setting)
    params = actor_params(params)  # a MAPPO run's critic only trains: the actor plays
    module = make_network(name, meta.get("history", DEFAULT_SETTING["history"]), state_channels(meta))
    params = _check(name, module, params, meta, source)
    return Learned(name, module, params, meta, source)


def train_state_template(module: Any, meta: dict, source: str) -> Any:
    """An initial A2C training state with the structure of a ``train.dcg`` checkpoint of ``meta`` (the restore target).

    Built like ``train.dcg`` builds it: the game of ``meta``, ``A2CConfig(**meta["algorithm"])`` and, for a MAPPO
    run (``algo``), its centralised critic.
    """
    from jaxdc.agents import a2c

    learned = Learned(meta["net"], module, None, meta, source)
    env, env_params = learned.game()
    fields = {f.name for f in dataclasses.fields(a2c.A2CConfig)}
    algo = {k: v for k, v in meta.get("algorithm", {}).items() if k in fields}
    try:
        config = a2c.A2CConfig(**algo)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{source}: the metadata has an unusable algorithm configuration: {e}") from None
    aux = opponent_labels(learned.collectors) if getattr(module, "has_aux", False) else None
    critic = build_critic(meta.get("algo", "ippo"))  # a MAPPO run's checkpoint holds its critic too
    return a2c.make_train(config, env, env_params, module, aux_target=aux, critic=critic).init(jax.random.PRNGKey(0))


def shipped_names() -> list[str]:
    """Names of the shipped DCG parameter files (``jaxdc/assets/dcg/*.msgpack``)."""
    return pretrained.shipped_names("dcg")


def shipped(name: str) -> Learned:
    """The shipped network ``name`` (e.g. ``"omn_conn"``; see :func:`shipped_names`)."""
    try:
        path = pretrained.shipped("dcg", name)
    except ValueError as e:
        raise ValueError(f"--net {name}: {e}; train one with `python -m train.dcg --net ...` and pass "
                         "--checkpoint RUN_FOLDER") from None
    return load(path)
