"""What each collector of the team DCG observes, and the world state of a centralised critic.

Each collector sees the DCG's observation (section 5.4.1) from its own seat, built by the DCG's observation
mixin (:class:`jaxdc.dcg.observation.CollectorObservation`) on its one-collector view
(:func:`jaxdc.dcg.team.state.collector_view`): ``M^item``, its own ``M^agent`` (its energy at its cell, -1
at every opponent cell it can see: opponent ``j`` is hidden from a collector in a fog cell under a
fog-hiding strategy of opponent ``j``), then -- with ``teammates=True`` -- one teammates plane (each
*active* teammate's energy at its cell, scaled as ``M^agent``; the largest where teammates share a cell),
then the ``"general"`` budget plane, then its own history. Stacked: ``[k, N, N, C]``. With
``teammates=False`` and one collector and opponent it is the DCG's observation exactly.

:meth:`TeamObservation.world_state` (for centralised critics, e.g. MAPPO) shows everything unhidden:
``M^item``, one energy plane per collector (its energy at its cell while active, else zeros), the
opponents' cells (-1, as in ``M^agent``), and the budget plane with ``"general"``: ``[N, N, 2 + k (+1)]``.
The team extension is the thesis' proposed next step (conclusion to chapter 5).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core.energy import ENERGY_SCALE, observed_energy
from jaxdc.dcg.team.state import TeamState, collector_view

if TYPE_CHECKING:
    from jaxdc.dcg.env import DCG

#: The teammates plane's channel: after ``M^item`` and ``M^agent`` (where a network trained without it is widened,
#: :func:`jaxdc.nets.transfer.widen_inputs`).
TEAMMATES_PLANE = 2


class TeamObservation:
    """The observation methods of :class:`jaxdc.dcg.team.env.DCGTeam`."""

    single: DCG
    collectors: int
    opponents: int
    teammates: bool
    grid_size: int

    @property
    def state_channels(self) -> int:
        """Channels of the current state: the DCG's (2, or 3 with ``"general"``) plus the teammates plane."""
        return self.single.state_channels + int(self.teammates)

    def observation_shape(self, params: Any = None) -> tuple[int, int, int, int]:
        """``(k, N, N, C)``: one DCG-style observation per collector."""
        n = self.grid_size
        return (self.collectors, n, n, self.state_channels + (self.single.history if self.single.obs_history else 0))

    def observation_bounds(self, params: Any) -> tuple[np.ndarray, np.ndarray]:
        """The DCG's bounds per collector (:meth:`~jaxdc.dcg.observation.CollectorObservation.observation_bounds`),
        the teammates plane in ``[0, max energy]`` (scaled as ``M^agent``)."""
        low, high = self.single.observation_bounds(params)
        if self.teammates:
            low = np.insert(low, TEAMMATES_PLANE, 0.0, axis=-1)
            high = np.insert(high, TEAMMATES_PLANE, high[..., 1], axis=-1)
        shape = self.observation_shape(params)
        return np.broadcast_to(low, shape).copy(), np.broadcast_to(high, shape).copy()

    def _energy_scale(self) -> float:
        return 1.0 if self.single.observation == "thesis" else ENERGY_SCALE

    def agent_planes(self, state: TeamState, params: Any) -> jax.Array:
        """``[k, N, N]``: each collector's observed ``M^agent`` (the DCG's plane of each opponent's view, the
        opponents' -1 cells merged by the minimum: energies are >= 0)."""
        def one(i, j):
            return self.single.observed_agent_plane(collector_view(state, i, j), params)

        ii, jj = jnp.arange(self.collectors), jnp.arange(self.opponents)
        return jnp.min(jax.vmap(lambda i: jax.vmap(lambda j: one(i, j))(jj))(ii), axis=1)

    def energy_planes(self, state: TeamState, params: Any) -> jax.Array:
        """``[k, N, N]``: collector ``i``'s observed energy at its cell while it is active, else zeros."""
        n = self.grid_size
        rows, cols = jnp.arange(n)[:, None], jnp.arange(n)[None, :]
        at = (rows == state.pos[:, 0, None, None]) & (cols == state.pos[:, 1, None, None])
        energy = observed_energy(state.energy, params.max_steps) / self._energy_scale()
        return jnp.where(at & state.active[:, None, None], energy[:, None, None], 0.0).astype(jnp.float32)

    def teammate_planes(self, state: TeamState, params: Any) -> jax.Array:
        """``[k, N, N]``: for collector ``i``, every other active collector's energy at its cell (the largest on a
        shared cell)."""
        planes = self.energy_planes(state, params)
        others = ~jnp.eye(self.collectors, dtype=bool)
        return jnp.max(jnp.where(others[:, :, None, None], planes[None], 0.0), axis=1)

    def observe(self, state: TeamState, params: Any) -> jax.Array:
        """``[k, N, N, C]``: per collector, the DCG's planes with its merged ``M^agent``, the teammates plane
        (``teammates=True``), the budget plane (``"general"``), its history (``obs_history``)."""
        base = jax.vmap(lambda i: self.single.planes(collector_view(state, i, 0), params))(
            jnp.arange(self.collectors))
        parts = [base[..., :1], self.agent_planes(state, params)[..., None]]
        if self.teammates:
            parts.append(self.teammate_planes(state, params)[..., None])
        parts.append(base[..., 2:])
        if self.single.obs_history:
            parts.append(state.history)
        return jnp.concatenate(parts, axis=-1)

    def world_state_shape(self) -> tuple[int, int, int]:
        """``(N, N, C)`` of :meth:`world_state`."""
        n = self.grid_size
        return (n, n, 2 + self.collectors + int(self.single.observation != "thesis"))

    def world_state(self, state: TeamState, params: Any) -> jax.Array:
        """Everything, unhidden (see the module docs): ``[N, N, 2 + k]``, ``+ 1`` budget plane with ``"general"``."""
        n = self.grid_size
        rows, cols = jnp.arange(n)[:, None], jnp.arange(n)[None, :]
        opp = jnp.any((rows == state.opponent.pos[:, 0, None, None]) & (cols == state.opponent.pos[:, 1, None, None]),
                      axis=0)
        parts = [state.items[..., None], jnp.moveaxis(self.energy_planes(state, params), 0, -1),
                 jnp.where(opp, -1.0, 0.0)[..., None].astype(jnp.float32)]
        if self.single.observation != "thesis":
            budget = observed_energy(self.single.max_energy_of(collector_view(state, 0), params), params.max_steps)
            parts.append(jnp.full((n, n, 1), budget / ENERGY_SCALE, jnp.float32))
        return jnp.concatenate(parts, axis=-1)
