"""Learned DCP policies (sections 4.4.3 and 4.5): load trained parameters and rebuild their setting.

A learned policy comes from one of three places:

* a **shipped** parameter file, ``jaxdc/assets/dcp/<name>.msgpack``
  (:func:`shipped_name` picks the one trained in a given setting);
* an **exported** parameter file written by :func:`jaxdc.pretrained.save`;
* a **run folder** of ``python -m train.dcp`` (its latest orbax checkpoint).

:func:`load` returns a :class:`Learned`: the network, its parameters and the
setting it was trained in (the metadata), whatever the source. Every source is
checked: a missing or damaged file, another problem or network, parameters
whose shapes do not fit the network on the requested grid, or parameters that
hold NaN or infinity (a diverged training run) raise a ``ValueError`` that
names the file and the problem.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from jaxdc import pretrained
from jaxdc.core.tree_check import check_like
from jaxdc.nets.registry import DCP_NETS, NSTEP_Q, build

#: Networks that have a learned DCP policy (the registry :data:`jaxdc.nets.registry.DCP_NETS`: ``enn``, ``linear``,
#: ``cnn``: A2C; ``eqn``: n-step Q).
NETS = tuple(DCP_NETS)
#: The evaluation epsilon of EQN's epsilon-greedy policy (section 4.5.5).
EQN_EPSILON = 0.05
#: Settings of the environment a network was trained in, as stored in its metadata.
SETTING_KEYS = ("grid_size", "total_reward", "risk", "energy", "max_steps")
#: Defaults of ``python -m train.dcp`` for metadata that predates a key.
DEFAULT_SETTING = {"grid_size": 8, "total_reward": 30, "risk": "high", "energy": [8.0, 16.0], "max_steps": 1000}
#: Environment options a network was trained with (``jaxdc.dcp.env.DCP``'s defaults when absent).
ENV_OPTION_KEYS = ("start", "items_on_base", "idle_terminates", "item_order")


def _setting_schema() -> dict[str, pretrained.SettingCheck]:
    """The checks of a DCP network's stored setting: those of ``train.dcp``'s and ``eval.dcp``'s flags (the
    constructor's choices and ranges), strict about JSON types."""
    from jaxdc.core import grid
    from jaxdc.core.energy import ENERGY_METRICS, MAX_ENERGY_TILT, MAX_FINITE_ENERGY
    from jaxdc.core.generators import GENERATORS
    from jaxdc.core.sampling import MAX_TILT, MAX_TOTAL_REWARD
    from jaxdc.core.validate import SEED_MAX
    from jaxdc.dcp import env as dcp_env
    from jaxdc.dcp.navigators import HEURISTIC_ROWS
    from jaxdc.nets.body import MAX_WIDTH, POOLS
    from jaxdc.pretrained import (
        json_bool,
        json_choice,
        json_int,
        json_list,
        json_number,
        json_object,
        json_string,
        optional,
    )

    budget = json_number(0.0, MAX_FINITE_ENERGY, low_open=True, allow_inf=True)
    return {
        "grid_size": json_int(2), "total_reward": json_int(1, MAX_TOTAL_REWARD),
        "risk": json_choice(sorted(grid.RISK_PRESETS)), "energy": json_list(budget, 2), "max_steps": json_int(1),
        "min_total_reward": optional(json_int(1, MAX_TOTAL_REWARD)), "observation": json_choice(dcp_env.OBSERVATIONS),
        "seed": json_int(0, SEED_MAX), "steps": json_int(1, None), "updates": json_int(1, None),
        "risk_maps": optional(json_choice(tuple(GENERATORS))), "map_seeds": optional(json_list(json_int(0), 2)),
        "energy_range": optional(json_list(json_number(0.0, MAX_FINITE_ENERGY, low_open=True), 2)),
        "energy_tilt": json_number(-MAX_ENERGY_TILT, MAX_ENERGY_TILT),
        "item_tilt": json_number(-MAX_TILT, MAX_TILT),
        "init_fraction": optional(json_number(0.0, 1.0)),
        "init_from": optional(json_string), "init_sha256": optional(json_string),
        "body_features": json_list(json_int(1, MAX_WIDTH)), "body_hidden": json_int(1, MAX_WIDTH),
        "body_pool": json_choice(POOLS), "grid_sizes": optional(json_list(json_int(2))),
        "heuristic_rows": json_int(min(HEURISTIC_ROWS), max(HEURISTIC_ROWS)),  # the row counts are consecutive
        "env": json_object({"start": json_choice(dcp_env.STARTS), "items_on_base": json_bool,
                            "idle_terminates": json_bool, "item_order": json_choice(dcp_env.ITEM_ORDERS),
                            "energy_metric": json_choice(ENERGY_METRICS)}),
    }


def check_setting(meta: dict, where: str) -> dict:
    """``meta`` if its stored setting passes the checks of the flags (:func:`_setting_schema`) and builds the
    environment of training; else a ``ValueError`` naming ``where`` (the file) and the key."""
    from jaxdc.dcp.env import DCP

    pretrained.check_settings(meta, where, _setting_schema())
    try:
        make_network(meta.get("net", "enn"), meta)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: its network does not build: {e}") from None
    s = {k: meta.get(k, DEFAULT_SETTING[k]) for k in SETTING_KEYS}
    energy = tuple(float(e) for e in s["energy"])  # "inf" reads as inf
    try:
        env = DCP(grid_size=s["grid_size"], total_reward=s["total_reward"], observation=observation_of(meta),
                  **{k: meta["env"][k] for k in ENV_OPTION_KEYS if k in meta.get("env", {})})
        env.make_params(s["risk"], energy, s["max_steps"])
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: its setting does not build the environment: {e}") from None
    return meta


def observation_of(meta: dict) -> str:
    """The observation a network was trained on (``"thesis"`` where the metadata predates the key)."""
    return meta.get("observation", "thesis")


@dataclasses.dataclass(frozen=True)
class Learned(pretrained.Learned):
    """A trained DCP network with its parameters and the metadata of how it was trained."""

    def setting(self) -> dict:
        """The environment setting of training: ``grid_size, total_reward, risk, energy, max_steps``."""
        return {k: self.metadata.get(k, DEFAULT_SETTING[k]) for k in SETTING_KEYS}

    def env_options(self) -> dict:
        """The ``DCP(...)`` options of training that change the dynamics (defaults where not recorded)."""
        return {k: self.metadata["env"][k] for k in ENV_OPTION_KEYS if k in self.metadata.get("env", {})}

    @property
    def observation(self) -> str:
        """``"thesis"`` or ``"general"``: what the network reads (:data:`jaxdc.dcp.env.OBSERVATIONS`)."""
        return observation_of(self.metadata)

    @property
    def heuristic_rows(self) -> int:
        """How many ENN heuristic rows the network reads (:func:`heuristic_rows`)."""
        return heuristic_rows(self.net)

    def policy(self, heuristics: Any = None, greedy: bool = False, epsilon: float = EQN_EPSILON,
               mask: Callable | None = None) -> Callable:
        """``policy(key, obs, state)`` of the network for :func:`jaxdc.core.rollout.run_episodes`.

        Actor-critics sample from ``pi`` (section 4.5: "the output of ENN is used
        as a stochastic policy"), or take its argmax if ``greedy``. EQN is
        epsilon-greedy with ``epsilon`` (section 4.5.5: 0.05; 0 if ``greedy``).
        ``mask`` (``state -> bool [A]``, :mod:`jaxdc.dcp.masks`; not in the thesis) restricts either to the
        allowed actions.
        """
        from jaxdc.agents import a2c, nstep_q

        if DCP_NETS[self.net_name].algorithm == NSTEP_Q:
            return nstep_q.make_q_policy(self.net, self.params, heuristics, epsilon=0.0 if greedy else epsilon,
                                         mask=mask)
        return a2c.make_policy(self.net, self.params, heuristics, greedy=greedy, mask=mask)

    def describe(self) -> str:
        """One line: network, training setting and source."""
        s = self.setting()
        return (f"{self.net_name} trained on {s['grid_size']}x{s['grid_size']}, risk {s['risk']}, "
                f"total reward {s['total_reward']}, energy {float(s['energy'][0]):g}/{float(s['energy'][1]):g}, "
                f"{_trained_for(self.metadata)}, seed {self.metadata.get('seed', '?')} ({self.source})")


#: The metadata keys that shape a network's convolutional body (beyond the thesis; absent: the thesis' body).
BODY_KEYS = ("body_features", "body_hidden", "body_pool")


def make_network(net_name: str, meta: dict | None = None) -> Any:
    """The flax module of ``net_name`` (ENN Fig. 4.3, EQN Fig. 4.4, linear learner Table 4.9, CNN), with the body
    its metadata ``meta`` records (:data:`BODY_KEYS`; none: the thesis' body) and, for ENN and EQN, the number of
    heuristic rows it reads (``heuristic_rows``; none: the thesis' ten)."""
    meta = meta or {}
    rows = meta.get("heuristic_rows")
    return build("dcp", net_name, **{k: meta[k] for k in BODY_KEYS if meta.get(k) is not None},
                 **({} if rows is None else {"num_heuristics": rows}))


def heuristic_rows(net: Any) -> int:
    """The number of ENN heuristic rows network module ``net`` reads: its ``num_heuristics`` (ENN, EQN; 10 is the
    thesis' rows, 11 adds Safe-Budget, :data:`jaxdc.dcp.navigators.BUDGET_HEURISTICS`), or 10 for a network that
    reads none (whose heuristics are ignored)."""
    return int(getattr(net, "num_heuristics", 10))


def init_params(net: Any, grid_size: int, key: jax.Array | None = None, observation: str = "thesis") -> Any:
    """Freshly initialised parameters of ``net`` for an ``grid_size x grid_size`` grid (shapes only matter)."""
    obs = jnp.zeros((1, grid_size, grid_size, 2 if observation == "thesis" else 4), jnp.float32)
    heur = (jnp.zeros((1, heuristic_rows(net), 9), jnp.float32) if getattr(net, "uses_heuristics", True)
            else jnp.zeros((1, 1, 9)))
    return net.init(key if key is not None else jax.random.PRNGKey(0), obs, heur)


def check_params(net_name: str, net: Any, params: Any, grid_size: int, source: str,
                 observation: str = "thesis") -> Any:
    """``params`` as float32 if it has exactly the structure and shapes of ``net`` on ``grid_size`` and every value
    is finite, else ``ValueError`` naming ``source``."""
    params = check_like(init_params(net, grid_size, observation=observation), params, source,
                        f"a {net_name} network on a {grid_size}x{grid_size} grid",
                        "was it trained on another grid size?")
    pretrained.check_finite(params, source)
    return params


def plays_any_grid(meta: dict) -> bool:
    """Whether the network of metadata ``meta`` plays every grid size: its body pools over the cells
    (``body_pool`` in :data:`jaxdc.nets.body.GRID_FREE_POOLS`), so its parameters do not depend on the grid."""
    from jaxdc.nets.body import GRID_FREE_POOLS

    return meta.get("body_pool") in GRID_FREE_POOLS


def _grid_checker(grid_size: int | None) -> Callable[[dict, str], None]:
    def check(meta: dict, source: str) -> None:
        have = meta.get("grid_size", DEFAULT_SETTING["grid_size"])
        if grid_size is not None and have != grid_size and not plays_any_grid(meta):
            raise ValueError(f"{source} was trained on a {have}x{have} grid; it cannot play a "
                             f"{grid_size}x{grid_size} grid (grid_size={grid_size})")
    return check


def load(path: pretrained.PathLike, net: str | None = None, grid_size: int | None = None,
         run_seed: int | None = None) -> Learned:
    """Load a learned policy from a parameter file (``.msgpack``) or a ``train.dcp`` run folder.

    ``net`` and ``grid_size``, when given, must match the stored metadata
    (else a ``ValueError`` names both values); the parameters must have the
    shapes of that network on that grid (:func:`jaxdc.pretrained.load_trained`).
    ``run_seed`` picks one seed of a ``train.dcp --seeds`` run folder.
    """
    name, params, meta, source = pretrained.load_trained(path, "dcp", NETS, _train_state, net,
                                                         _grid_checker(grid_size), run_seed=run_seed,
                                                         check_setting=check_setting)
    module = make_network(name, meta)
    params = check_params(name, module, params, meta.get("grid_size", DEFAULT_SETTING["grid_size"]), source,
                          observation_of(meta))
    return Learned(name, module, params, meta, source)


def _train_state(name: str, meta: dict, source: str) -> Any:
    """An initial training state with the structure of a ``train.dcp`` checkpoint of ``meta`` (restore target)."""
    from jaxdc.agents import a2c, nstep_q
    from jaxdc.core.paths import safest_paths
    from jaxdc.dcp import instances, navigators
    from jaxdc.dcp.env import DCP

    s = {k: meta.get(k, DEFAULT_SETTING[k]) for k in SETTING_KEYS}
    env = DCP(grid_size=s["grid_size"], total_reward=s["total_reward"], observation=observation_of(meta))
    env_params = env.make_params(s["risk"], tuple(s["energy"]), s["max_steps"])
    per_episode = "risk_maps" in meta or "energy_range" in meta
    q_learning = DCP_NETS[name].algorithm == NSTEP_Q
    cls = nstep_q.QConfig if q_learning else a2c.A2CConfig
    fields = {f.name for f in dataclasses.fields(cls)}
    algo = {k: v for k, v in meta.get("algorithm", {}).items() if k in fields}
    try:
        config = cls(**algo)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{source}: the metadata has an unusable algorithm configuration: {e}") from None
    net = make_network(name, meta)
    if per_episode:  # the state's structure only: one map stands for the run's set
        env_params = instances.fixed_instance(env, s["risk"], tuple(s["energy"]), s["max_steps"])
        heur = instances.batched_heuristics(env_params, rows=heuristic_rows(net))
    else:
        heur = navigators.batched_heuristics(env_params, safest_paths(env_params.risk), rows=heuristic_rows(net))
    extra = []  # a run over several grid sizes (grid_sizes) holds one group of environments per size
    for n in [n for n in meta.get("grid_sizes") or () if n != s["grid_size"]]:
        other = DCP(grid_size=n, total_reward=s["total_reward"], observation=observation_of(meta))
        params = instances.fixed_instance(other, s["risk"], tuple(s["energy"]), s["max_steps"])
        extra.append(a2c.EnvGroup(other, params, instances.batched_heuristics(params, rows=heuristic_rows(net))))
    more = {"extra_envs": tuple(extra)} if extra else {}
    trainer = (nstep_q if q_learning else a2c).make_train(config, env, env_params, net, heur, **more)
    return trainer.init(jax.random.PRNGKey(0))


def shipped_name(net: str, risk: str = "high", energy: tuple[float, float] = (8.0, 16.0)) -> str:
    """Name of the shipped parameter file of ``net`` trained with ``risk`` and ``energy`` (section 4.5).

    The ENN of Table 4.3 (high risk, energy 8/16) is ``"enn"``; the ENN of
    Table 4.7 (energy 16/32) is ``"enn_energy16_32"``; the linear learner and
    EQN (Tables 4.9, 4.10, setting of Table 4.3) are ``"linear"`` and ``"eqn"``.
    Other settings are named ``"<net>_<risk>"`` and ``"<net>_energy<I>_<M>"``.
    """
    name = net
    if risk != "high":
        name += f"_{risk}"
    init_e, max_e = (float(e) for e in energy)
    if (init_e, max_e) != (8.0, 16.0):
        name += f"_energy{init_e:g}_{max_e:g}"
    return name


def shipped(net: str, risk: str = "high", energy: tuple[float, float] = (8.0, 16.0),
            grid_size: int | None = None) -> Learned:
    """The shipped learned policy of ``net`` trained in the given risk and energy setting (see :func:`shipped_name`)."""
    name = shipped_name(net, risk, energy)
    try:
        path = pretrained.shipped("dcp", name)
    except ValueError as e:
        raise ValueError(f"no shipped {net} trained with risk={risk!r}, energy={tuple(energy)} ({e}); "
                         "train one with `python -m train.dcp` and pass --checkpoint RUN_FOLDER") from None
    return load(path, net=net, grid_size=grid_size)


def _trained_for(meta: dict) -> str:
    if "steps" in meta:
        return f"{meta['steps']} steps"
    return f"{meta['updates']} updates" if "updates" in meta else "? steps"
