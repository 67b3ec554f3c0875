"""What the DCG collector observes (section 5.4.1): the item and agent planes, the history, and the
``"general"`` observation's budget plane (beyond the thesis, docs/generalisation.md).

:class:`CollectorObservation` is a base of :class:`jaxdc.dcg.env.DCG`: it reads the game's ``grid_size``,
``observation``, ``history``, ``obs_history``, ``total_reward``, opponent strategies and ``max_energy_of``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core.energy import ENERGY_SCALE, observed_energy, observed_energy_bound
from jaxdc.dcg import opponents as opp_lib

if TYPE_CHECKING:
    import jaxdc.dcg.env


class CollectorObservation:
    """The observation methods of the DCG (section 5.4.1)."""

    grid_size: int
    observation: str
    history: int
    obs_history: bool
    total_reward: int
    _strategies: Any

    def max_energy_of(self, state: jaxdc.dcg.env.EnvState, params: jaxdc.dcg.env.EnvParams) -> jax.Array:
        raise NotImplementedError

    @property
    def state_channels(self) -> int:
        """Channels of the current state at the front of an observation: 2 (thesis), 3 (``"general"``: + budget)."""
        return 2 if self.observation == "thesis" else 3

    def observation_shape(self, params: jaxdc.dcg.env.EnvParams | None = None) -> tuple[int, int, int]:
        return (self.grid_size, self.grid_size, self.state_channels + (self.history if self.obs_history else 0))

    def observation_bounds(self, params: jaxdc.dcg.env.EnvParams) -> tuple[np.ndarray, np.ndarray]:
        """Items in ``[0, total_reward]``; agent and history planes in ``[-1, max_energy]`` (the opponent is -1;
        ``max_steps`` stands for unlimited energy); ``"general"``: energies (and the budget plane, in
        ``[0, max_energy]``) over :data:`~jaxdc.core.energy.ENERGY_SCALE`."""
        shape = self.observation_shape(params)
        scale = 1.0 if self.observation == "thesis" else ENERGY_SCALE
        low = np.full(shape, -1.0, np.float32)
        high = np.full(shape, observed_energy_bound(params.max_energy, params.max_steps) / scale, np.float32)
        low[..., 0], high[..., 0] = 0.0, self.total_reward
        if self.observation != "thesis":
            low[..., 2] = 0.0
        return low, high


    def opponent_hidden(self, state: jaxdc.dcg.env.EnvState) -> jax.Array:
        """Whether the collector cannot see the opponent: a fog-hiding strategy and the collector in the fog."""
        hides = jnp.asarray([s.hides_in_fog for s in self._strategies])
        return hides[state.strategy] & opp_lib.in_fog(state.pos)

    def agent_plane(self, state: jaxdc.dcg.env.EnvState, params: jaxdc.dcg.env.EnvParams) -> jax.Array:
        """``M^agent`` as the collector observes it (section 5.4.1), ``[N, N]``.

        The collector's energy at its cell, -1 at the opponent's (drawn over the
        collector when they share a cell), 0 elsewhere; the opponent is left out
        while :meth:`opponent_hidden`. An unlimited budget shows as ``max_steps``
        (:func:`~jaxdc.core.energy.observed_energy`).
        """
        n = self.grid_size
        rows, cols = jnp.arange(n)[:, None], jnp.arange(n)[None, :]
        me = (rows == state.pos[0]) & (cols == state.pos[1])
        opp = (rows == state.opponent.pos[0]) & (cols == state.opponent.pos[1]) & ~self.opponent_hidden(state)
        energy = observed_energy(state.energy, params.max_steps)
        return jnp.where(opp, -1.0, jnp.where(me, energy, 0.0)).astype(jnp.float32)

    def observed_agent_plane(self, state: jaxdc.dcg.env.EnvState, params: jaxdc.dcg.env.EnvParams) -> jax.Array:
        """:meth:`agent_plane` as the observation (and its history) shows it: ``"general"`` divides the energy by
        :data:`~jaxdc.core.energy.ENERGY_SCALE` (the opponent stays -1)."""
        plane = self.agent_plane(state, params)
        return plane if self.observation == "thesis" else jnp.where(plane > 0, plane / ENERGY_SCALE, plane)

    def planes(self, state: jaxdc.dcg.env.EnvState, params: jaxdc.dcg.env.EnvParams) -> jax.Array:
        """The current state ``s_t`` as two planes ``[N, N, 2]``: ``M^item``, ``M^agent``; ``"general"``: three,
        ``M^agent`` scaled, then the episode's maximum energy over the scale on every cell."""
        if self.observation == "thesis":
            return jnp.stack([state.items, self.agent_plane(state, params)], axis=-1)
        n = self.grid_size
        budget = observed_energy(self.max_energy_of(state, params), params.max_steps) / ENERGY_SCALE
        return jnp.stack([state.items, self.observed_agent_plane(state, params),
                          jnp.full((n, n), budget, jnp.float32)], axis=-1)

    def observe(self, state: jaxdc.dcg.env.EnvState, params: jaxdc.dcg.env.EnvParams) -> jax.Array:
        """``[N, N, 2 + k]`` (planes then history) with ``obs_history``, else ``[N, N, 2]`` (``"general"``: 3 state
        planes)."""
        planes = self.planes(state, params)
        if self.obs_history:
            return jnp.concatenate([planes, state.history], axis=-1)
        return planes
