"""Action masks for DCP policies (beyond the thesis: an option, never the default; docs/generalisation.md).

A mask is ``mask(state) -> bool [A]`` for one environment state: the actions a policy may take. A masked
actor-critic samples (or takes the argmax) among the allowed actions only; a masked Q-policy takes the best
allowed action and explores among the allowed ones (:func:`jaxdc.agents.common.masked_logits`).

``"reach_base"``: **the budget still reaches the base**. Section 4.3 disables the agent when its energy reaches
0 outside the base; with 9 actions (diagonals included) the base at ``(0, 0)`` is ``max(row, col)`` moves from
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

from typing import Callable

import jax
import jax.numpy as jnp

from jaxdc.core import grid
from jaxdc.core.validate import check_choice
from jaxdc.dcp.env import DCP, EnvState

#: The masks by name (``none``: every action is allowed, the thesis' policy).
MASKS = ("none", "reach_base", "reach_base_or_item")

Mask = Callable[[EnvState], jax.Array]


def _chebyshev(cells: jax.Array, targets: jax.Array, n: int) -> jax.Array:
    """Moves (diagonals allowed) from each of ``cells [A, 2]`` to the nearest cell where ``targets [N, N]``."""
    rows, cols = jnp.meshgrid(jnp.arange(n), jnp.arange(n), indexing="ij")
    d = jnp.maximum(jnp.abs(cells[:, 0, None, None] - rows), jnp.abs(cells[:, 1, None, None] - cols))
    return jnp.min(jnp.where(targets, d, 2 * n), axis=(1, 2)).astype(jnp.float32)


def _mask(env: DCP, or_item: bool) -> Mask:
    n, actions = env.grid_size, jnp.arange(grid.NUM_ACTIONS)

    def mask(state: EnvState) -> jax.Array:
        nxt = grid.move(state.pos, actions, n)  # [A, 2]
        reach = jnp.max(nxt, axis=-1).astype(jnp.float32)  # moves from the base (0, 0)
        safe = reach == 0
        if or_item:
            reach = jnp.minimum(reach, _chebyshev(nxt, state.items > 0, n))
            safe = safe | (state.items[nxt[:, 0], nxt[:, 1]] > 0)
        allowed = safe | (state.energy - 1.0 >= jnp.maximum(reach, 1.0))
        return allowed | ~jnp.any(allowed)

    return mask


def reach_base(env: DCP) -> Mask:
    """The mask "the budget still reaches the base" of ``env`` (module docstring)."""
    return _mask(env, or_item=False)


def reach_base_or_item(env: DCP) -> Mask:
    """The mask "the budget still reaches the base or an item" of ``env``: :func:`reach_base`, but a move may
    also take an item, or leave the energy to reach one (section 4.3 pays the item before the energy check, so
    a last item is worth the agent)."""
    return _mask(env, or_item=True)


def make_mask(name: str, env: DCP) -> Mask | None:
    """The mask called ``name`` (one of :data:`MASKS`) for ``env``; ``None`` for ``"none"``."""
    check_choice("mask", name, MASKS)
    return None if name == "none" else _mask(env, or_item=name == "reach_base_or_item")
