"""The environment of one DCP evaluation (section 4.3): its setting and the DCP options it is played with.

:func:`evaluation_setting` settles the grid size, risk, total reward, energy
and step cap: a thesis table (section 4.5) fixes risk, total reward and
energy; otherwise each is the given value, else the learned network's (how
it was trained), else :data:`DEFAULT_SETTING`. :func:`make_env` builds the
environment; a learned network plays the dynamics it was trained with.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from jaxdc.dcp.env import DCP, EnvParams
from jaxdc.dcp.instances import fixed_instance
from jaxdc.dcp.learned import plays_any_grid

#: Setting of a heuristic evaluation when not given (Table 4.3: high risk, total reward 30, energy 8/16).
DEFAULT_SETTING = {"risk": "high", "total_reward": 30, "energy": (8.0, 16.0), "max_steps": 1000}


@dataclasses.dataclass(frozen=True)
class Setting:
    """Grid size, risk (a Table 4.2 preset name or an ``N x N`` map), total reward, energy and step cap."""

    grid_size: int
    total_reward: int
    risk: str | np.ndarray
    energy: tuple[float, float]
    max_steps: int


@dataclasses.dataclass(frozen=True)
class EnvOptions:
    """The ``DCP(...)`` options of the thesis' ambiguities (docs/ambiguities.md) for a heuristic evaluation."""

    start: str = "random_free"
    items_on_base: bool = True
    energy_metric: str = "not_stay_in_base"
    idle_terminates: bool = True
    item_order: str = "drop"

    def kwargs(self, learned=None) -> dict:
        """``DCP(...)`` keyword arguments; a learned network keeps those it was trained with (never an idle stop)."""
        options = dict(start=self.start, items_on_base=self.items_on_base, energy_metric=self.energy_metric,
                       idle_terminates=self.idle_terminates, item_order=self.item_order)
        if learned is not None:
            options.update(idle_terminates=False, observation=learned.observation)
            options.update(learned.env_options())
        return options


def evaluation_setting(spec=None, learned=None, *, risk=None, total_reward=None, energy=None, max_steps=None,
                       grid_size=None, risk_map: np.ndarray | None = None) -> Setting:
    """The :class:`Setting` of an evaluation of table ``spec`` (a :class:`jaxdc.dcp.analysis.tables.TableSpec`) or not.

    ``risk``, ``total_reward`` and ``energy`` count only without ``spec``;
    ``max_steps`` and ``grid_size`` always win; a ``risk_map`` replaces the
    risk and gives the grid size unless ``grid_size`` is given. Raises a
    ``ValueError`` if ``learned`` was trained on another grid size, unless its body pools over the cells
    (:func:`jaxdc.dcp.learned.plays_any_grid`: it plays every grid size).
    """
    s = dict(DEFAULT_SETTING, grid_size=None)
    if learned is not None:
        s.update(learned.setting())
    if spec is not None:
        s.update(risk=spec.risk, total_reward=spec.total_reward, energy=spec.energy)
    else:
        given = {"risk": risk, "total_reward": total_reward, "energy": energy}
        s.update({k: v for k, v in given.items() if v is not None})
    if max_steps is not None:
        s["max_steps"] = max_steps
    if risk_map is not None:
        s["risk"] = risk_map
        s["grid_size"] = grid_size or risk_map.shape[0]
    else:
        s["grid_size"] = grid_size or s["grid_size"] or 8
    if (learned is not None and s["grid_size"] != learned.setting()["grid_size"]
            and not plays_any_grid(learned.metadata)):
        g = learned.setting()["grid_size"]
        raise ValueError(f"{learned.source} was trained on a {g}x{g} grid; it cannot play a "
                         f"{s['grid_size']}x{s['grid_size']} grid")
    return Setting(grid_size=s["grid_size"], total_reward=s["total_reward"], risk=s["risk"],
                   energy=tuple(float(e) for e in s["energy"]), max_steps=s["max_steps"])


def make_env(setting: Setting, options: EnvOptions = EnvOptions(), learned=None) -> tuple[DCP, EnvParams]:
    """The DCP of ``setting`` and its parameters; ``learned`` plays with the options and the observation it was
    trained with. A network that reads the instance (the ``"general"`` observation, beyond the thesis) plays the
    setting's map and budget through the per-episode path (:func:`jaxdc.dcp.instances.fixed_instance`), as it
    was trained."""
    env = DCP(grid_size=setting.grid_size, total_reward=setting.total_reward, **options.kwargs(learned))
    if learned is not None and learned.observation != "thesis":
        return env, fixed_instance(env, setting.risk, setting.energy, setting.max_steps)
    return env, env.make_params(setting.risk, setting.energy, max_steps=setting.max_steps)
