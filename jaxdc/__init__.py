"""jaxdc: JAX toolkit for risk-aware navigation of data-collecting UAVs (DRP, DCP, DCG).

Importing :mod:`jaxdc` registers ``"jaxdc/DCP-v0"`` and ``"jaxdc/DCG-v0"`` with gymnasium
(``gymnasium.make`` / ``gymnasium.make_vec``; the adapters live in
:mod:`jaxdc.wrappers.gymnasium` and are imported only when an env is made). The two
environments and their parameter and state records are exported under names that say
whose they are (``DCPParams``, ``DCGState``, ...).
"""

from __future__ import annotations

from typing import Any

from jaxdc._version import __version__
from jaxdc.dcg.env import DCG
from jaxdc.dcg.env import EnvParams as DCGParams
from jaxdc.dcg.env import EnvState as DCGState
from jaxdc.dcg.team import DCGTeam
from jaxdc.dcg.team import TeamState as DCGTeamState
from jaxdc.dcp.env import DCP
from jaxdc.dcp.env import EnvParams as DCPParams
from jaxdc.dcp.env import EnvState as DCPState

__all__ = ["DCG", "DCGParams", "DCGState", "DCGTeam", "DCGTeamState", "DCP", "DCPParams", "DCPState", "make",
           "registered_envs", "__version__"]

_GYM_ID = "jaxdc/DCP-v0"
_DCG_GYM_ID = "jaxdc/DCG-v0"
#: keyword arguments that go to ``make_params`` rather than the constructor, per environment
_DCG_PARAM_KEYS = ("energy", "max_steps", "chase_tie", "energy_range", "energy_tilt")
_PARAM_KEYS = {"DCP-v0": ("risk", "energy", "max_steps"), "DCG-v0": _DCG_PARAM_KEYS, "DCGTeam-v0": _DCG_PARAM_KEYS}
#: the environment class of each id
_ENVS = {"DCP-v0": DCP, "DCG-v0": DCG, "DCGTeam-v0": DCGTeam}


def _register() -> None:
    try:
        import gymnasium
    except ImportError:  # gymnasium is a dependency, but keep the functional core usable without it
        return
    if _GYM_ID not in gymnasium.registry:
        gymnasium.register(
            id=_GYM_ID,
            entry_point="jaxdc.wrappers.gymnasium:make_dcp",
            vector_entry_point="jaxdc.wrappers.gymnasium:make_dcp_vector",
            # gymnasium's PassiveEnvChecker marks its first reset done before calling ours, so a refused first
            # reset broke its first step (TypeError from the checker); jaxdc's adapters check their input
            # themselves and the tests run gymnasium's full check_env.
            disable_env_checker=True,
        )
    if _DCG_GYM_ID not in gymnasium.registry:
        gymnasium.register(
            id=_DCG_GYM_ID,
            entry_point="jaxdc.wrappers.gymnasium:make_dcg",
            vector_entry_point="jaxdc.wrappers.gymnasium:make_dcg_vector",
            # gymnasium's PassiveEnvChecker marks its first reset done before calling ours, so a refused first
            # reset broke its first step (TypeError from the checker); jaxdc's adapters check their input
            # themselves and the tests run gymnasium's full check_env.
            disable_env_checker=True,
        )


_register()


def registered_envs() -> tuple[str, ...]:
    """The ids :func:`make` accepts (``"DCP-v0"``, ``"DCG-v0"``, ``"DCGTeam-v0"``; gymnasium knows the first two
    as ``"jaxdc/<id>"``; the multi-agent team game has the JaxMARL-style adapter :mod:`jaxdc.wrappers.jaxmarl`)."""
    return tuple(_PARAM_KEYS)


def make(id: str, **kwargs: Any) -> tuple[Any, Any]:
    """``(env, params)`` of the functional environment ``id`` (one of :func:`registered_envs`), gymnax style::

        env, params = jaxdc.make("DCP-v0", risk="low", grid_size=6)
        obs, state = env.reset(key, params)

    The keywords of ``make_params`` (DCP: ``risk``, ``energy``, ``max_steps``;
    DCG: ``energy``, ``max_steps``, ``chase_tie``; DCGTeam: those and
    ``energy_range``) go there, the others to the environment's constructor
    (``jaxdc.make("DCGTeam-v0", collectors=2)``).
    """
    name = id.removeprefix("jaxdc/")
    if name not in _PARAM_KEYS:
        raise ValueError(f"unknown environment id {id!r}; available: {sorted(_PARAM_KEYS)}")
    params_kwargs = {k: kwargs.pop(k) for k in _PARAM_KEYS[name] if k in kwargs}
    env = _ENVS[name](**kwargs)
    return env, env.make_params(**params_kwargs)
