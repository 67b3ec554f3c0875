"""The energy rule of the grid problems (DCP section 4.3, DCG section 5.3) and what "energy consumed" counts.

After its move, the agent's energy drops by one unless it is in the base
``(0, 0)``, where it refills to the maximum; it is disabled when the energy
reaches 0 outside the base. Both problems apply this rule; their episode
statistics count the energy consumed by one of :data:`ENERGY_METRICS`.
Pure functions of arrays (``jit``/``vmap``).
"""

from __future__ import annotations

import jax.numpy as jnp

#: What "energy consumed" counts (Tables 4.3-4.10; docs/ambiguities.md): ``"not_stay_in_base"`` -- every step
#: except one that starts and ends in the base; ``"outside_base"`` -- steps that end outside the base (the actual
#: decrements); ``"all_steps"`` -- every step.
ENERGY_METRICS = ("not_stay_in_base", "outside_base", "all_steps")


def step_energy(energy, max_energy, in_base):
    """``(energy, out_of_energy)`` after a move: refilled to ``max_energy`` in the base, else one less (not below 0);
    ``out_of_energy`` when it is 0 outside the base."""
    energy = jnp.where(in_base, max_energy, jnp.maximum(energy - 1.0, 0.0))
    return energy, ~in_base & (energy <= 0)


def energy_used(metric: str, in_base, was_in_base):
    """Whether the step counts as energy consumed under ``metric`` (:data:`ENERGY_METRICS`, static): ``in_base``
    and ``was_in_base`` say where the agent ends and started the step."""
    if metric == "not_stay_in_base":
        return ~(in_base & was_in_base)
    if metric == "outside_base":
        return ~in_base
    if metric == "all_steps":
        return jnp.bool_(True)
    raise ValueError(f"energy_metric must be one of {ENERGY_METRICS}, got {metric!r}")
