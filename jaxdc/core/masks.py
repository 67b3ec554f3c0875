"""Action masks for the grid problems' policies (beyond the thesis: an option, never the default;
docs/generalisation.md).

The DCP (section 4.3) and the DCG (section 5.3) share the energy rule: one unit per move outside the base at
``(0, 0)``, a refill there, the agent disabled at 0. A mask reads what both states hold -- ``pos [2]``,
``energy`` and ``items [N, N]`` -- so one mask serves both (:mod:`jaxdc.dcp.masks` builds it from a DCP,
:meth:`jaxdc.dcg.learned.Learned.policy` from a DCG).

A mask is ``mask(state) -> bool [A]`` for one environment state: the actions a policy may take. A masked
actor-critic samples (or takes the argmax) among the allowed actions only; a masked Q-policy takes the best
allowed action and explores among the allowed ones (:func:`jaxdc.agents.common.masked_logits`).

``"reach_base"``: **the budget still reaches the base**. Sections 4.3 and 5.3 disable the agent when its energy
reaches 0 outside the base; with 9 actions (diagonals included) the base at ``(0, 0)`` is ``max(row, col)`` moves from
a cell, and those moves cost one energy each except the last, which lands in the base and refills it. So from
a cell at distance ``d > 0`` holding energy ``e`` the agent can still get home iff ``e >= d``; an action is
allowed iff it ends in the base or leaves ``e - 1 >= max(d', 1)`` energy at its cell (``d'`` its distance).
When no action is allowed (a start far from the base with little energy, which the thesis' random start can
give) every action is, so a mask never leaves a policy without a move. Unlimited energy allows everything.

The mask forbids nothing the navigators do not already avoid (Algorithm 9 only goes for an item when the
energy covers the way back): it removes the one failure a network can fall into and a plan cannot, running dry.
It also forbids taking a last item at the price of the agent, which can be worth it near the end of an episode.
"""

from __future__ import annotations

from typing import Any, Callable, Protocol

import jax
import jax.numpy as jnp

from jaxdc.core import grid
from jaxdc.core.validate import check_choice

#: The masks by name (``none``: every action is allowed, the thesis' policy).
MASKS = ("none", "reach_base", "reach_base_or_item")


class AgentState(Protocol):
    """What a mask reads of one environment state (the DCP's and the DCG's ``EnvState``)."""

    pos: jax.Array  # [2] int32 (row, col)
    energy: jax.Array  # float32
    items: jax.Array  # [N, N] reward per cell


Mask = Callable[[Any], jax.Array]


def _chebyshev(cells: jax.Array, targets: jax.Array, n: int) -> jax.Array:
    """Moves (diagonals allowed) from each of ``cells [A, 2]`` to the nearest cell where ``targets [N, N]``."""
    rows, cols = jnp.meshgrid(jnp.arange(n), jnp.arange(n), indexing="ij")
    d = jnp.maximum(jnp.abs(cells[:, 0, None, None] - rows), jnp.abs(cells[:, 1, None, None] - cols))
    return jnp.min(jnp.where(targets, d, 2 * n), axis=(1, 2)).astype(jnp.float32)


def _mask(grid_size: int, or_item: bool) -> Mask:
    n, actions = grid_size, jnp.arange(grid.NUM_ACTIONS)

    def mask(state: AgentState) -> jax.Array:
        nxt = grid.move(state.pos, actions, n)  # [A, 2]
        reach = jnp.max(nxt, axis=-1).astype(jnp.float32)  # moves from the base (0, 0)
        safe = reach == 0
        if or_item:
            reach = jnp.minimum(reach, _chebyshev(nxt, state.items > 0, n))
            safe = safe | (state.items[nxt[:, 0], nxt[:, 1]] > 0)
        allowed = safe | (state.energy - 1.0 >= jnp.maximum(reach, 1.0))
        return allowed | ~jnp.any(allowed)

    return mask


def make_mask(name: str, grid_size: int) -> Mask | None:
    """The mask called ``name`` (one of :data:`MASKS`) on an ``grid_size x grid_size`` grid; ``None`` for
    ``"none"``. ``reach_base_or_item`` is ``reach_base`` except that a move may also take an item, or leave the
    energy to reach one (sections 4.3 and 5.3 pay the item before the energy check, so a last item is worth
    the agent)."""
    check_choice("mask", name, MASKS)
    return None if name == "none" else _mask(grid_size, or_item=name == "reach_base_or_item")


__all__ = ["MASKS", "AgentState", "Mask", "make_mask"]
