"""The Data-collection Problem (DCP), thesis section 4.3.

An ``N x N`` grid MDP: per-cell risk, items of unit rewards dropped
multinomially, an energy budget that refills in the base at ``(0, 0)``.

One transition (section 4.3), in this order:

1. the agent moves (clipped per axis at the border);
2. it collects the item in the new cell;
3. it is disabled with that cell's risk;
4. its energy drops by one unless it is in the base, where it refills to the
   maximum; it is disabled when the energy reaches 0.

The episode *terminates* when the agent is disabled or every item is
collected (and optionally when a step leaves the state unchanged, see
``idle_terminates``); the step cap ``max_steps`` *truncates* it.

The observation is the thesis' two planes (section 4.4.3, "The CNN in ENN"),
stacked channels-last as ``[N, N, 2]``: ``M^item`` (item rewards) and
``M^agent`` (the energy at the agent's cell, 0 elsewhere).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core import grid
from jaxdc.core.energy import (
    ENERGY_METRICS,
    ENERGY_SCALE,
    draw_max_energy,
    energy_used,
    observed_energy,
    observed_energy_bound,
    step_energy,
)
from jaxdc.core.env import Environment, Transition
from jaxdc.core.sampling import (
    MAX_RANGE,
    MAX_TILT,
    MAX_TOTAL_REWARD,
    drop_units,
    power_law_integer,
    running_count,
    uniform_index,
)
from jaxdc.core.scene import Scene
from jaxdc.core.validate import INT32_MAX, check_bool, check_float, check_int, check_positive_int, is_int
from jaxdc.dcp.param_values import check_energy, check_param_values
from jaxdc.dcp.types import CLEARED, ENERGY, IDLE, OUTCOMES, RISK, RUNNING, TRUNCATED, EnvParams, EnvState

#: Where the agent starts (an ambiguity of section 4.3: "the initial locations ... are random").
STARTS = ("random_free", "random", "base")
#: The order of items that breaks ties in the planners ("first item" of Algorithms 7-8).
ITEM_ORDERS = ("drop", "row_major")
#: What the agent observes: the thesis' two planes, or four planes a network can generalise from (beyond the
#: thesis: the risk map and the budget, docs/generalisation.md).
OBSERVATIONS = ("thesis", "general")


class DCP(Environment[EnvState, EnvParams]):
    """The DCP environment (section 4.3) with the gymnax-style functional API.

    Args:
      grid_size: ``N`` (>= 2).
      total_reward: number of unit rewards dropped multinomially over the
        cells at reset; the units on one cell form one item (section 4.4.1).
      start: ``"random_free"`` (a uniformly random cell without an item; the
        default, which reproduces Tables 4.3-4.8 best), ``"random"`` (any
        cell) or ``"base"``.
      items_on_base: whether the multinomial drop may put items on the base
        cell (the thesis draws over "the 8 x 8 options").
      energy_metric: what "energy consumed" counts: ``"not_stay_in_base"``
        (every step except one that starts and ends in the base; default),
        ``"outside_base"`` (steps that end outside the base, i.e. the actual
        decrements) or ``"all_steps"``.
      item_order: the order of the item list that Algorithms 7 and 8 iterate,
        which decides ties between equally good items: ``"drop"`` (the order
        in which the multinomial drop first hit each cell, i.e. a random
        order; default, which reproduces Tables 4.3-4.8 best) or
        ``"row_major"`` (cell order).
      idle_terminates: end the episode (outcome ``idle``) when a step leaves
        the state unchanged. A deterministic policy would then repeat that
        step forever, so for the navigators this only saves time; keep it
        off for stochastic policies.
      min_total_reward: ``None`` (default, the thesis): every episode drops
        ``total_reward`` units. An int ``1 <= m <= total_reward``: each
        episode drops a number of units drawn uniformly from
        ``m .. total_reward`` (a training distribution beyond the thesis, for
        one network that plays Tables 4.3, 4.6 and 4.8; docs/learning.md).
      item_tilt: with ``min_total_reward``, 0 (default: the count is uniform
        on ``min_total_reward .. total_reward``) or the tilt ``a`` of a power
        law, ``|a| <= MAX_TILT`` (:func:`jaxdc.core.sampling.power_law_integer`:
        count ``c`` with the mass of ``x ** -a`` over ``[c, c + 1)``), so a
        positive tilt weights the episodes with few items (``a = 1``:
        log-uniform). Beyond the thesis: a training distribution for one
        network that plays one item as well as many
        (docs/generalisation.md).
      observation: ``"thesis"`` (default): the two planes of section 4.4.3.
        ``"general"`` (beyond the thesis): four planes ``[N, N, 4]``: items,
        the energy at the agent's cell, the episode's risk map and its
        maximum energy on every cell, both energies divided by
        :data:`~jaxdc.core.energy.ENERGY_SCALE`; a network that sees them can play maps and
        budgets it was not trained on (docs/generalisation.md).

    With per-episode instances (``params.maps``, built by
    :func:`jaxdc.dcp.instances.instance_params`) each reset draws the
    episode's risk map from ``params.maps`` and its maximum energy from
    ``params.energy_range``; the state keeps them (``map_id``,
    ``max_energy``).
    """

    outcomes: tuple[str, ...] = OUTCOMES
    state_type = EnvState
    params_type = EnvParams

    def __init__(
        self,
        grid_size: int = 8,
        total_reward: int = 30,
        start: str = "random_free",
        items_on_base: bool = True,
        energy_metric: str = "not_stay_in_base",
        idle_terminates: bool = False,
        item_order: str = "drop",
        min_total_reward: int | None = None,
        observation: str = "thesis",
        item_tilt: float = 0.0,
    ) -> None:
        self.grid_size = grid.check_grid_size(grid_size, max_cells=MAX_RANGE)  # the drop's uniform_index range
        check_int("total_reward", total_reward, 1, MAX_TOTAL_REWARD)
        if min_total_reward is not None:
            if not is_int(min_total_reward):
                raise TypeError(f"min_total_reward must be None or an int, got {min_total_reward!r}")
            if not 1 <= min_total_reward <= total_reward:
                raise ValueError(
                    f"min_total_reward must be in [1, total_reward={total_reward}], got {min_total_reward}")
        item_tilt = check_float("item_tilt", item_tilt, -MAX_TILT, MAX_TILT)
        if item_tilt != 0.0 and min_total_reward is None:
            raise ValueError(f"item_tilt={item_tilt:g} tilts the draw of the item count from min_total_reward to "
                             "total_reward and needs min_total_reward: without it, item_tilt must be 0")
        if start not in STARTS:
            raise ValueError(f"start must be one of {STARTS}, got {start!r}")
        if energy_metric not in ENERGY_METRICS:
            raise ValueError(f"energy_metric must be one of {ENERGY_METRICS}, got {energy_metric!r}")
        if item_order not in ITEM_ORDERS:
            raise ValueError(f"item_order must be one of {ITEM_ORDERS}, got {item_order!r}")
        if observation not in OBSERVATIONS:
            raise ValueError(f"observation must be one of {OBSERVATIONS}, got {observation!r}")
        self.observation = observation
        self.total_reward = int(total_reward)
        self.start = start
        self.items_on_base = check_bool("items_on_base", items_on_base)
        self.energy_metric = energy_metric
        self.idle_terminates = check_bool("idle_terminates", idle_terminates)
        self.item_order = item_order
        self.min_total_reward = None if min_total_reward is None else int(min_total_reward)
        self.item_tilt = item_tilt

    def _config(self) -> tuple:
        return (self.grid_size, self.total_reward, self.start, self.items_on_base,
                self.energy_metric, self.idle_terminates, self.item_order, self.min_total_reward) + (
                    () if self.observation == "thesis" else (self.observation,)) + (
                    () if self.item_tilt == 0.0 else (("item_tilt", self.item_tilt),))

    def __repr__(self) -> str:
        return (
            f"DCP(grid_size={self.grid_size}, total_reward={self.total_reward}, start={self.start!r}, "
            f"items_on_base={self.items_on_base}, energy_metric={self.energy_metric!r}, "
            f"idle_terminates={self.idle_terminates}, item_order={self.item_order!r}"
            + ("" if self.min_total_reward is None else f", min_total_reward={self.min_total_reward}")
            + ("" if self.observation == "thesis" else f", observation={self.observation!r}")
            + ("" if self.item_tilt == 0.0 else f", item_tilt={self.item_tilt:g}") + ")"
        )

    # -- parameters -------------------------------------------------------------------
    def make_params(self, risk: Any = "high", energy: Any = (8.0, 16.0), max_steps: int = 1000) -> EnvParams:
        """Validated :class:`EnvParams`.

        Args:
          risk: a preset of Table 4.2 (``"low"``, ``"medium"``, ``"high"``) or an
            ``N x N`` array with values in ``[0, 1]`` and base risk 0.
          energy: ``(initial, maximum)``; ``float("inf")`` for no constraint.
          max_steps: the step cap (>= 1) that truncates an episode.
        """
        risk = grid.as_risk_map(risk, self.grid_size)
        init_e, max_e = check_energy(energy)
        check_positive_int("max_steps", max_steps, high=INT32_MAX)
        return EnvParams(
            risk=jnp.asarray(risk, jnp.float32),
            init_energy=jnp.float32(init_e),
            max_energy=jnp.float32(max_e),
            max_steps=jnp.int32(max_steps),
        )

    def check_param_values(self, params: EnvParams) -> EnvParams:
        """``params`` if their values are ones :meth:`make_params` accepts
        (:func:`jaxdc.dcp.param_values.check_param_values`)."""
        return check_param_values(params)

    def grid_shapes(self) -> tuple[dict[str, tuple[int, ...]], dict[str, tuple[int, ...]]]:
        """The grid-shaped fields: the risk map(s) of the parameters, the items and ranks of the state."""
        n = (self.grid_size, self.grid_size)
        return {"risk": n, "maps": n}, {"items": n, "rank": n, "pos": (2,)}

    def observation_shape(self, params: EnvParams | None = None) -> tuple[int, int, int]:
        return (self.grid_size, self.grid_size, 2 if self.observation == "thesis" else 4)

    def observation_bounds(self, params: EnvParams) -> tuple[float, np.ndarray]:
        """Items in ``[0, total_reward]``; the energy plane in ``[0, observed_energy_bound(...)]`` (the budget, or
        ``max_steps`` for an unlimited one); ``"general"``: both energy planes over
        :data:`~jaxdc.core.energy.ENERGY_SCALE`, the risk plane in ``[0, 1]``."""
        high = np.zeros(self.observation_shape(params), np.float32)
        high[..., 0] = self.total_reward
        if params.energy_range is not None:
            energy = float(np.max(np.asarray(params.energy_range)))
        else:
            energy = observed_energy_bound(params.max_energy, params.max_steps, params.init_energy)
        if self.observation == "thesis":
            high[..., 1] = energy
        else:
            high[..., 1] = high[..., 3] = energy / ENERGY_SCALE
            high[..., 2] = 1.0
        return 0.0, high

    # -- the episode's instance -------------------------------------------------------
    def risk_of(self, state: EnvState, params: EnvParams) -> jax.Array:
        """The episode's risk map ``[N, N]``: ``params.risk``, or the map the episode drew from ``params.maps``."""
        return params.risk if params.maps is None else params.maps[state.map_id]

    def max_energy_of(self, state: EnvState, params: EnvParams) -> jax.Array:
        """The episode's maximum energy: ``params.max_energy``, or the one the episode drew."""
        return params.max_energy if state.max_energy is None else state.max_energy

    def _draw_instance(self, key, params: EnvParams):
        """``(map_id, init_energy, max_energy)`` of a new episode with per-episode instances."""
        assert params.maps is not None and params.energy_range is not None and params.init_fraction is not None
        k_map, k_energy = jax.random.split(key)
        map_id = uniform_index(k_map, (), params.maps.shape[0])
        max_e = draw_max_energy(k_energy, params.energy_range, params.energy_tilt)
        init_e = jnp.clip(jnp.round(params.init_fraction * max_e), 1.0, max_e).astype(jnp.float32)
        return map_id, init_e, max_e

    # -- dynamics ---------------------------------------------------------------------
    def reset_env(self, key: jax.Array, params: EnvParams) -> tuple[jax.Array, EnvState]:
        """A random initial state (section 4.3): multinomial items, then the start cell."""
        n = self.grid_size
        instance = {}
        init_energy = params.init_energy
        if params.maps is not None:  # per-episode instance: its own key, so the rest draws as without one
            key, k_instance = jax.random.split(key)
            map_id, init_energy, max_e = self._draw_instance(k_instance, params)
            instance = {"map_id": map_id, "max_energy": max_e}
        k_items, k_start = jax.random.split(key)
        count = None
        if self.min_total_reward is not None:  # units drawn from min_total_reward .. total_reward
            k_items, k_count = jax.random.split(k_items)
            if self.item_tilt == 0.0:  # uniformly
                span = self.total_reward - self.min_total_reward + 1
                count = self.min_total_reward + uniform_index(k_count, (), span)
            else:  # by the power law of item_tilt
                count = power_law_integer(k_count, float(self.min_total_reward), float(self.total_reward),
                                          self.item_tilt).astype(jnp.int32)
        items, first = drop_units(k_items, self.total_reward, n * n, 0 if self.items_on_base else 1, count)
        rank = first if self.item_order == "drop" else jnp.arange(n * n, dtype=jnp.int32)
        if self.start == "base":
            flat = jnp.int32(0)
        elif self.start == "random":
            flat = uniform_index(k_start, (), n * n)
        else:  # random_free: the k-th free cell for k uniform; any cell if none is free
            free = items == 0
            free = jnp.where(free.any(), free, True)
            count = running_count(free)
            k = uniform_index(k_start, (), count[-1])
            # the first cell whose running count exceeds k (searchsorted(count, k, "right"), as a sum: a
            # vectorised compare instead of a per-environment binary search)
            flat = jnp.sum(count <= k, dtype=jnp.int32)
        state = EnvState(
            pos=jnp.stack([flat // n, flat % n]).astype(jnp.int32),
            energy=init_energy,
            items=items.reshape(n, n),
            time=jnp.int32(0),
            outcome=jnp.int32(RUNNING),
            ep_reward=jnp.float32(0.0),
            ep_energy=jnp.int32(0),
            rank=rank.reshape(n, n),
            **instance,
        )
        return self.observe(state, params), state

    def step_env(self, key: jax.Array, state: EnvState, action: Any, params: EnvParams) -> Transition:
        """One transition of section 4.3, without auto-reset."""
        return self.step_with_noise(self.step_noise(key, None, params), state, action, params)

    def step_noise(self, key: jax.Array, batch: int | None, params: EnvParams) -> jax.Array:
        """The step's one random number: the uniform the risk of the cell entered is compared with (per
        environment, or ``[batch]`` from one key: :func:`jaxdc.core.batched.step_batched`)."""
        return jax.random.uniform(key, () if batch is None else (batch,))

    def step_with_noise(self, noise: jax.Array, state: EnvState, action: Any, params: EnvParams) -> Transition:
        """:meth:`step_env` given its uniform ``noise``: the agent is disabled when ``noise`` is below the risk."""
        n = self.grid_size
        action, invalid = grid.clip_action(action)
        pos = grid.move(state.pos, action, n)
        reward = state.items[pos[0], pos[1]]
        items = state.items.at[pos[0], pos[1]].set(0.0)
        hit = noise < self.risk_of(state, params)[pos[0], pos[1]]
        in_base = jnp.all(pos == 0)
        energy, out_of_energy = step_energy(state.energy, self.max_energy_of(state, params), in_base)
        cleared = jnp.all(items <= 0)
        used = energy_used(self.energy_metric, in_base, jnp.all(state.pos == 0))
        unchanged = (
            jnp.all(pos == state.pos) & (energy == state.energy) & (reward == 0) & ~hit & ~out_of_energy
        )
        idle = unchanged if self.idle_terminates else jnp.bool_(False)
        time = state.time + 1
        outcome = jnp.select(
            [hit, out_of_energy, cleared, idle, time >= params.max_steps],
            [RISK, ENERGY, CLEARED, IDLE, TRUNCATED],
            RUNNING,
        ).astype(jnp.int32)
        terminated = (outcome != RUNNING) & (outcome != TRUNCATED)
        truncated = outcome == TRUNCATED
        new_state = dataclasses.replace(
            state,
            pos=pos,
            energy=energy,
            items=items,
            time=time,
            outcome=outcome,
            ep_reward=state.ep_reward + reward,
            ep_energy=state.ep_energy + used.astype(jnp.int32),
        )
        info = {
            "outcome": outcome,
            "episode_reward": new_state.ep_reward,
            "episode_energy": new_state.ep_energy,
            "episode_steps": time,
            "invalid_action": invalid,
        }
        return self.observe(new_state, params), new_state, reward, terminated, truncated, info

    def observe(self, state: EnvState, params: EnvParams) -> jax.Array:
        """The two planes ``[N, N, 2]``: item rewards and the energy at the agent's cell (section 4.5.1; an
        unlimited budget shows as ``max_steps``, :func:`~jaxdc.core.energy.observed_energy`). ``"general"``:
        then the episode's risk map and its maximum energy on every cell, energies over
        :data:`~jaxdc.core.energy.ENERGY_SCALE`."""
        n = self.grid_size
        here = (jnp.arange(n)[:, None] == state.pos[0]) & (jnp.arange(n)[None, :] == state.pos[1])
        agent = jnp.where(here, observed_energy(state.energy, params.max_steps), 0.0).astype(jnp.float32)
        if self.observation == "thesis":
            return jnp.stack([state.items, agent], axis=-1)
        budget = observed_energy(self.max_energy_of(state, params), params.max_steps) / ENERGY_SCALE
        return jnp.stack([state.items, agent / ENERGY_SCALE, self.risk_of(state, params),
                          jnp.full((n, n), budget, jnp.float32)], axis=-1)

    # -- text rendering (outside jit) ----------------------------------------------------
    def render_ansi(self, state: EnvState, params: EnvParams) -> str:
        """Text grid (:func:`render_ansi`): ``A`` agent, ``B`` base, item digits, ``.`` empty, then a status line."""
        shown = params if state.max_energy is None else dataclasses.replace(params, max_energy=state.max_energy)
        return render_ansi(state, shown)

    def scene(self, state: EnvState, params: EnvParams) -> Scene:
        """The frame of section 4.3 (:func:`jaxdc.viewer.render_frame`): the risk map with its values (Fig. 4.1b),
        the items, the agent with its energy."""
        return Scene(items=np.asarray(state.items), agent=np.asarray(state.pos), energy=state.energy,
                     max_energy=self.max_energy_of(state, params), reward=state.ep_reward, step=int(state.time),
                     outcome=OUTCOMES[int(state.outcome)], risk=np.asarray(self.risk_of(state, params)))


def _fmt(x: Any) -> str:
    x = float(x)
    if np.isinf(x):
        return "inf"
    return str(int(x)) if x == int(x) else f"{x:g}"


def render_ansi(state: Any, params: Any) -> str:
    """Text grid of a DCP-like state (outside jit): ``B`` base, ``A`` agent, item reward digits
    (``*`` above 9; ``+`` below 1), ``.`` empty; one row per line, then a status line."""
    items = np.asarray(state.items)
    pos = tuple(int(p) for p in np.asarray(state.pos))
    n = items.shape[0]
    rows = []
    for r in range(n):
        cells = []
        for c in range(n):
            if (r, c) == pos:
                ch = "A"
            elif (r, c) == (0, 0):
                ch = "B"
            elif items[r, c] > 0:
                v = float(items[r, c])
                ch = "*" if v > 9 else str(int(round(v))) if v >= 1 else "+"
            else:
                ch = "."
            cells.append(ch)
        rows.append(" ".join(cells))
    status = f"energy {_fmt(state.energy)}/{_fmt(params.max_energy)}"
    if hasattr(state, "ep_reward"):
        status += f", reward {_fmt(state.ep_reward)}"
    if hasattr(state, "time"):
        status += f", step {int(state.time)}"
    rows.append(status)
    return "\n".join(rows) + "\n"

