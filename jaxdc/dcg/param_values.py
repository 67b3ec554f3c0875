"""The values of the DCG's parameters, checked on concrete arrays (issue 31; section 5.3's settings).

:func:`check_param_values` applies the checks of :meth:`jaxdc.dcg.env.DCG.make_params` to a whole
:class:`~jaxdc.dcg.types.EnvParams`, for parameters that bypassed it (edited with ``.replace``):
:meth:`jaxdc.dcg.env.DCG.check_param_values` (and the team game's) runs it once at the non-jitted entry
points.
"""

from __future__ import annotations

import numpy as np

from jaxdc.core.energy import check_budget, check_energy_range, check_energy_tilt
from jaxdc.core.env import check_each, is_traced
from jaxdc.core.validate import INT32_MAX, check_int
from jaxdc.dcg.opponents import CHASE_TIES
from jaxdc.dcg.types import EnvParams

#: The smallest maximum energy of an ``energy_range``: the smallest whole budget (one step out of the base).
MIN_RANGE_ENERGY = 1.0


def check_param_values(params: EnvParams, name: str = "params") -> EnvParams:
    """``params`` if their VALUES are those :meth:`jaxdc.dcg.env.DCG.make_params` accepts: ``max_energy`` > 0
    (finite or ``inf``), ``max_steps`` an int in ``[1, 2**31 - 1]``, ``chase_tie`` an index into
    :data:`~jaxdc.dcg.opponents.CHASE_TIES`, and, with a drawn budget, ``energy_range`` whole numbers
    ``MIN_RANGE_ENERGY <= low <= high`` and ``energy_tilt`` in range. Else a ``TypeError``/``ValueError`` naming
    ``name.<field>``, the value and the allowed range. Traced parameters (inside ``jit``/``vmap``) are returned
    unchecked."""
    if is_traced(params):
        return params
    check_each(params, "max_energy", lambda v: check_budget("max_energy", v), name)
    check_each(params, "max_steps", lambda v: check_int("max_steps", v, 1, INT32_MAX), name)
    check_each(params, "chase_tie", lambda v: check_int("chase_tie (an index into CHASE_TIES)", v, 0,
                                                        len(CHASE_TIES) - 1), name)
    if params.energy_range is not None:
        try:
            check_energy_range(np.asarray(params.energy_range).tolist(), MIN_RANGE_ENERGY)
        except (TypeError, ValueError) as e:
            raise type(e)(f"{name}.energy_range: {e}") from None
    if params.energy_tilt is not None:
        check_each(params, "energy_tilt", check_energy_tilt, name)
    return params


__all__ = ["MIN_RANGE_ENERGY", "check_param_values"]
