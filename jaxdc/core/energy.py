"""The energy rule of the grid problems (DCP section 4.3, DCG section 5.3) and what "energy consumed" counts.

After its move, the agent's energy drops by one unless it is in the base
``(0, 0)``, where it refills to the maximum; it is disabled when the energy
reaches 0 outside the base. Both problems apply this rule; their episode
statistics count the energy consumed by one of :data:`ENERGY_METRICS`.
The step functions are pure functions of arrays (``jit``/``vmap``); the
budget check runs outside jit, at ``make_params``.

Unlimited energy (``inf``, Table 4.1) is a state, never an observation: the
observation shows :func:`observed_energy`, which writes an infinite budget as
the step cap ``max_steps``. An episode moves at most ``max_steps`` times and a
move costs at most one unit, so a budget of ``max_steps`` can never run out
either: the two mean the same game, and the number stays finite.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxdc.core.sampling import MAX_TILT, power_law_integer
from jaxdc.core.validate import check_float, value_text

#: The largest finite budget: float32 counts every unit exactly up to 2**24, so ``energy - 1`` always lowers it.
MAX_FINITE_ENERGY = float(2**24)
#: The largest magnitude of a power-law tilt of drawn maximum energies (:func:`draw_max_energy`; beyond the thesis).
MAX_ENERGY_TILT = MAX_TILT

#: The fixed scale of the energy planes of the ``"general"`` observations (DCP and DCG, beyond the thesis;
#: docs/generalisation.md): energies are divided by it, so any budget up to 64 shows in [0, 1] and larger ones stay
#: finite (the observation space grows with the budget).
ENERGY_SCALE = 64.0

#: What "energy consumed" counts (Tables 4.3-4.10; docs/ambiguities.md): ``"not_stay_in_base"`` -- every step
#: except one that starts and ends in the base; ``"outside_base"`` -- steps that end outside the base (the actual
#: decrements); ``"all_steps"`` -- every step.
ENERGY_METRICS = ("not_stay_in_base", "outside_base", "all_steps")


def step_energy(energy: Any, max_energy: Any, in_base: Any) -> tuple[jax.Array, jax.Array]:
    """``(energy, out_of_energy)`` after a move: refilled to ``max_energy`` in the base, else one less (not below 0);
    ``out_of_energy`` when it is 0 outside the base."""
    energy = jnp.where(in_base, max_energy, jnp.maximum(energy - 1.0, 0.0))
    return energy, ~in_base & (energy <= 0)


def observed_energy(energy: Any, max_steps: Any) -> jax.Array:
    """The energy as an observation shows it: a finite budget as it is, ``inf`` as ``max_steps`` (finite)."""
    return jnp.where(jnp.isinf(energy), jnp.asarray(max_steps, jnp.float32), energy)


def observed_energy_bound(max_energy: Any, max_steps: Any, init_energy: Any = None) -> float:
    """The largest energy an observation can show (outside jit): ``max_energy``, or, when it is unlimited,
    ``max_steps`` or a larger finite ``init_energy`` (shown until the first refill)."""
    budgets = [float(max_energy)] + ([] if init_energy is None else [float(init_energy)])
    finite = [b for b in budgets if b != float("inf")]
    return max(finite + ([float(max_steps)] if len(finite) < len(budgets) else []))


def check_budget(name: str, value: Any) -> float:
    """An energy budget: a number > 0, at most :data:`MAX_FINITE_ENERGY` or ``inf`` (no constraint)."""
    return check_float(name, value, 0.0, MAX_FINITE_ENERGY, low_open=True, allow_inf=True)


def check_energy_range(energy_range: Any, minimum: float = 2.0, name: str = "energy_range") -> tuple[float, float]:
    """``(low, high)``: whole, finite maximum energies with ``minimum <= low <= high <= MAX_FINITE_ENERGY`` (a range
    of per-episode budgets, beyond the thesis). The errors name ``name``, the bound and the value."""
    try:
        low, high = energy_range
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a pair (low, high), got {energy_range!r}") from None
    low = check_float(f"{name} low", low, minimum, MAX_FINITE_ENERGY)
    high = check_float(f"{name} high", high, minimum, MAX_FINITE_ENERGY)
    for which, v in (("low", low), ("high", high)):
        if v != int(v):
            raise ValueError(f"{name} {which} must be a whole number, got {value_text(v)}")
    if low > high:
        raise ValueError(f"{name}: low ({value_text(low)}) must not exceed high ({value_text(high)})")
    return low, high


def check_energy_tilt(tilt: Any, name: str = "energy_tilt") -> float:
    """A power-law tilt of a drawn maximum energy (:func:`draw_max_energy`): a finite number in
    ``[-MAX_ENERGY_TILT, MAX_ENERGY_TILT]``; 0 is the uniform draw. The error names ``name``, the range and the
    value."""
    return check_float(name, tilt, -MAX_ENERGY_TILT, MAX_ENERGY_TILT)


def draw_max_energy(key: jax.Array, energy_range: jax.Array, tilt: jax.Array | None = None) -> jax.Array:
    """A maximum energy drawn among the integers of ``energy_range = [low, high]`` (float32; jit/vmap).

    ``tilt`` ``None`` (or 0): uniformly. Otherwise (beyond the thesis) a power law
    (:func:`jaxdc.core.sampling.power_law_integer`): each integer ``E`` has probability proportional to the
    integral of ``x ** -tilt`` over ``[E, E + 1)`` (``tilt = 1`` is log-uniform), so a positive tilt weights the
    low budgets, a negative one the high ones."""
    return power_law_integer(key, energy_range[0], energy_range[1], tilt)


def energy_used(metric: str, in_base: Any, was_in_base: Any) -> jax.Array:
    """Whether the step counts as energy consumed under ``metric`` (:data:`ENERGY_METRICS`, static): ``in_base``
    and ``was_in_base`` say where the agent ends and started the step."""
    if metric == "not_stay_in_base":
        return ~(in_base & was_in_base)
    if metric == "outside_base":
        return ~in_base
    if metric == "all_steps":
        return jnp.bool_(True)
    raise ValueError(f"energy_metric must be one of {ENERGY_METRICS}, got {metric!r}")
