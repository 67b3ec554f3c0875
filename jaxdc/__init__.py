"""jaxdc: JAX toolkit for risk-aware navigation of data-collecting UAVs (DRP, DCP, DCG).

Importing :mod:`jaxdc` registers ``"jaxdc/DCP-v0"`` and ``"jaxdc/DCG-v0"`` with gymnasium
(``gymnasium.make`` / ``gymnasium.make_vec``; the adapters live in
:mod:`jaxdc.wrappers.gymnasium` and are imported only when an env is made).
"""

from __future__ import annotations

from jaxdc.dcp.env import DCP, EnvParams, EnvState

__version__ = "0.1.0"
__all__ = ["DCP", "EnvParams", "EnvState", "make", "__version__"]

_GYM_ID = "jaxdc/DCP-v0"
_PARAM_KEYS = ("risk", "energy", "max_steps")
_DCG_GYM_ID = "jaxdc/DCG-v0"


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
        )
    if _DCG_GYM_ID not in gymnasium.registry:
        gymnasium.register(
            id=_DCG_GYM_ID,
            entry_point="jaxdc.wrappers.gymnasium:make_dcg",
            vector_entry_point="jaxdc.wrappers.gymnasium:make_dcg_vector",
        )


_register()


def make(id: str, **kwargs):
    """``(env, params)`` of the functional environment ``id`` (``"DCP-v0"``).

    ``risk``, ``energy`` and ``max_steps`` go to ``DCP.make_params``; the other
    kwargs to the :class:`DCP` constructor. (The DCG: ``jaxdc.dcg.DCG(...)`` and
    its ``make_params``, or ``gymnasium.make("jaxdc/DCG-v0")``.)
    """
    if id not in ("DCP-v0", _GYM_ID):
        raise ValueError(f"unknown environment id {id!r}; available: ['DCP-v0']")
    params_kwargs = {k: kwargs.pop(k) for k in _PARAM_KEYS if k in kwargs}
    env = DCP(**kwargs)
    return env, env.make_params(**params_kwargs)
