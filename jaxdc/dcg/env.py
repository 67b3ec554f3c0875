"""The Data-collection Game (DCG), thesis section 5.3 with the settings of 5.5.1.

A collector and an opponent on an ``N x N`` grid with the base at ``(0, 0)``.
The collector starts in the base with full energy; the opponent on a random
cell; ``total_reward`` unit rewards are dropped multinomially over the cells
(with ``reward_area=s``: over the bottom-right ``s x s`` square, one unit item
by default, the experiment of section 5.5.5, Figs. 5.10-5.12).
The opponent's strategy (:mod:`jaxdc.dcg.opponents`) is drawn uniformly per
episode from the configured set.

One transition (section 5.3), in this order:

1. the opponent moves (its action ``o_t``); if it lands on the collector's
   cell, the collector is disabled and does not move;
2. otherwise the collector moves (clipped per axis) and collects the item in
   its new cell;
3. if it ends on the opponent's cell, it is disabled (the item of step 2
   still counts by default, see ``reward_when_caught``);
4. its energy drops by one unless it is in the base, where it refills to the
   maximum; it is disabled when the energy reaches 0.

The episode *terminates* when the collector is disabled or every item is
collected; the step cap ``max_steps`` *truncates* it (the thesis shows games
that never end).

Observation (section 5.4.1), channels-last: ``M^item`` (item rewards),
``M^agent`` (the collector's energy at its cell, -1 at the opponent's cell,
0 elsewhere; with a fog-hiding strategy the opponent is left out while the
collector is in a fog cell), and -- with ``obs_history=True`` -- the ``k``
previous agent planes ``M^agent_{t-1} .. M^agent_{t-k}`` (the history ``h``
of sections 5.4.3-5.4.5), kept in the state so that everything stays pure.

Beyond the thesis (its conclusion: "changing the maximum energy level often
means a fresh network needs to be trained"; docs/generalisation.md): with
``make_params(energy_range=(low, high))`` each reset draws the episode's
maximum energy uniformly among the integers of the range (or, with
``energy_tilt``, by a power law that weights one end) (the collector starts
with it and refills to it); the state keeps it (``max_energy``). The
``"general"`` observation shows it: a budget plane after ``M^agent``, and every
energy divided by :data:`~jaxdc.core.energy.ENERGY_SCALE`.
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
    check_budget,
    check_energy_range,
    check_energy_tilt,
    draw_max_energy,
    energy_used,
    step_energy,
)
from jaxdc.core.env import Environment, Transition
from jaxdc.core.sampling import MAX_RANGE, MAX_TOTAL_REWARD, drop_units, uniform_index
from jaxdc.core.scene import Scene
from jaxdc.core.validate import INT32_MAX, check_bool, check_choice, check_int, is_int
from jaxdc.dcg import opponents as opp_lib
from jaxdc.dcg import picture
from jaxdc.dcg.observation import CollectorObservation
from jaxdc.dcg.opponents import CHASE_TIES, STANDARD_STRATEGIES, OpponentState
from jaxdc.dcg.param_values import MIN_RANGE_ENERGY, check_param_values
from jaxdc.dcg.types import CAUGHT, CLEARED, ENERGY, OUTCOMES, RUNNING, TRUNCATED, EnvParams, EnvState

#: Where the opponent starts ("the locations of the opponent and items are randomly selected").
OPPONENT_STARTS = ("not_base", "any")
#: The far end of the patrol ("a random location other than the base").
PATROL_TARGETS = ("other", "any_non_base")
#: What the history holds before the first step.
HISTORY_FILLS = ("zeros", "first")
#: Readings of the capture rule (section 5.3): "both" -- the opponent lands on the collector (1) or the
#: collector moves onto the opponent (3); "opponent_moves" -- only (1).
CAPTURES = ("both", "opponent_moves")
#: Energy on a step where the opponent lands on the collector before it moves (rule 1): "charged" -- one unit,
#: "regardless of what action was taken"; "uncharged" -- the step ends before the energy rule.
CAUGHT_ENERGIES = ("charged", "uncharged")
#: What the collector observes: the thesis' planes, or the ``"general"`` ones that show the episode's budget.
OBSERVATIONS = ("thesis", "general")
#: The key of an episode's budget draw is ``fold_in(reset key, ENERGY_STREAM)``: the rest of the reset draws as
#: without a range, so a range ``(E, E)`` plays the same games as the fixed energy ``E``.
ENERGY_STREAM = 0x454E


class DCG(CollectorObservation, Environment[EnvState, EnvParams]):
    """The DCG environment (section 5.3) with the gymnax-style functional API.

    Args:
      grid_size: ``N`` (>= 2); 5 in the thesis.
      total_reward: unit rewards dropped multinomially at reset; default 10
        (5.5.1), or 1 with ``reward_area`` (section 5.5.5: "only 1 item with
        1 reward").
      strategies: names of registered opponent strategies (see
        :func:`jaxdc.dcg.opponents.register_strategy`), one drawn uniformly
        per episode; ``info["strategy"]`` is the index into this tuple.
      history: ``k`` (>= 1), the number of previous agent planes kept (10).
      obs_history: observations are ``[N, N, 2 + k]`` (state plus history,
        the input of IMNN/EMNN/OMN/CoNN; VNN takes ``obs[..., :2]``) when
        true, else only the two planes ``[N, N, 2]``.
      history_fill: the history at reset: ``"zeros"`` (no history yet) or
        ``"first"`` (every slot holds the first agent plane).
      items_on_base: whether the drop may put items on the base (5.5.1 drops
        over all 25 cells).
      opponent_start: ``"not_base"`` (uniform over the cells other than the
        base, i.e. never on the collector) or ``"any"``.
      patrol_target: the patrol's far end: ``"other"`` (uniform over the
        non-base cells other than its start, so that it really moves back and
        forth) or ``"any_non_base"`` (may equal the start: it then stays).
      reward_when_caught: whether the item collected on the step the
        collector ends on the opponent's cell (step 3) counts.
      energy_metric: what ``info["episode_energy"]`` counts (as for the DCP).
      reward_area: ``None`` (the drop covers the whole grid) or the size ``s``
        (``1 <= s <= grid_size``) of the *reward area* of section 5.5.5 (Fig.
        5.10): the units are dropped uniformly over the ``s x s`` square in the
        bottom-right corner, rows and columns ``N-s .. N-1`` (the base only
        when ``s == N`` and ``items_on_base``). The opponent's start is drawn
        as without it, so it may start on the item.
      min_reward_area: ``None`` (default: every episode uses ``reward_area``)
        or a size ``m`` with ``1 <= m <= reward_area``: each episode first draws
        its square's size uniformly from ``m .. reward_area``, then drops the
        units over that square. A training distribution beyond the thesis (one
        network for every reward-area size, docs/dcg.md), as the DCP's
        ``min_total_reward`` is for the item count.
      observation: ``"thesis"`` (default): the planes above. ``"general"``
        (beyond the thesis): ``M^item``, ``M^agent`` with the energy divided
        by :data:`~jaxdc.core.energy.ENERGY_SCALE`, then the episode's maximum
        energy over the same scale on every cell, then the history (scaled
        agent planes): ``[N, N, 3 + k]``, so one network can play every budget
        (docs/generalisation.md).
    """

    outcomes: tuple[str, ...] = OUTCOMES
    state_type = EnvState
    params_type = EnvParams

    def __init__(
        self,
        grid_size: int = 5,
        total_reward: int | None = None,
        strategies: Any = STANDARD_STRATEGIES,
        history: int = 10,
        obs_history: bool = True,
        history_fill: str = "zeros",
        items_on_base: bool = True,
        opponent_start: str = "not_base",
        patrol_target: str = "other",
        reward_when_caught: bool = True,
        energy_metric: str = "not_stay_in_base",
        reward_area: int | None = None,
        capture: str = "both",
        safe_base: bool = False,
        opponent_enters_base: bool = True,
        caught_energy: str = "charged",
        min_reward_area: int | None = None,
        observation: str = "thesis",
    ) -> None:
        self.grid_size = grid.check_grid_size(grid_size, max_cells=MAX_RANGE)  # the drop's uniform_index range
        if reward_area is not None:
            reward_area = check_int("reward_area", reward_area, 1)
            if reward_area > self.grid_size:
                raise ValueError(
                    f"reward_area must be between 1 and grid_size ({self.grid_size}), got {reward_area}")
        self.reward_area = reward_area
        if min_reward_area is not None:
            if reward_area is None:
                raise ValueError(f"min_reward_area={min_reward_area!r} needs a reward_area")
            min_reward_area = check_int("min_reward_area", min_reward_area, 1)
            if min_reward_area > reward_area:
                raise ValueError(f"min_reward_area must be between 1 and reward_area ({reward_area}), "
                                 f"got {min_reward_area}")
        self.min_reward_area = min_reward_area
        if total_reward is None:
            total_reward = 10 if reward_area is None else 1
        self.total_reward = check_int("total_reward", total_reward, 1, MAX_TOTAL_REWARD)
        self._strategies = opp_lib.get_strategies(strategies)
        self.strategies = tuple(s.name for s in self._strategies)
        self.history = check_int("history (k)", history, 1)
        self.obs_history = check_bool("obs_history", obs_history)
        self.history_fill = check_choice("history_fill", history_fill, HISTORY_FILLS)
        self.items_on_base = check_bool("items_on_base", items_on_base)
        self.opponent_start = check_choice("opponent_start", opponent_start, OPPONENT_STARTS)
        self.patrol_target = check_choice("patrol_target", patrol_target, PATROL_TARGETS)
        self.reward_when_caught = check_bool("reward_when_caught", reward_when_caught)
        self.energy_metric = check_choice("energy_metric", energy_metric, ENERGY_METRICS)
        self.capture = check_choice("capture", capture, CAPTURES)
        self.caught_energy = check_choice("caught_energy", caught_energy, CAUGHT_ENERGIES)
        self.observation = check_choice("observation", observation, OBSERVATIONS)
        self.safe_base = check_bool("safe_base", safe_base)
        self.opponent_enters_base = check_bool("opponent_enters_base", opponent_enters_base)
        if not self.opponent_enters_base and self.opponent_start != "not_base":
            raise ValueError(f"opponent_enters_base=False needs opponent_start='not_base', got {opponent_start!r}")

    def _config(self) -> tuple:
        return (self.grid_size, self.total_reward, self._strategies, self.history, self.obs_history,
                self.history_fill, self.items_on_base, self.opponent_start, self.patrol_target,
                self.reward_when_caught, self.energy_metric, self.reward_area, self.capture, self.safe_base,
                self.opponent_enters_base, self.caught_energy, self.min_reward_area) + (
                    () if self.observation == "thesis" else (self.observation,))

    def __repr__(self) -> str:
        return (
            f"DCG(grid_size={self.grid_size}, total_reward={self.total_reward}, strategies={self.strategies}, "
            f"history={self.history}, obs_history={self.obs_history}, history_fill={self.history_fill!r}, "
            f"items_on_base={self.items_on_base}, opponent_start={self.opponent_start!r}, "
            f"patrol_target={self.patrol_target!r}, reward_when_caught={self.reward_when_caught}, "
            f"energy_metric={self.energy_metric!r}, reward_area={self.reward_area}"
            + ("" if self.default_rules() else
               f", capture={self.capture!r}, safe_base={self.safe_base}, "
               f"opponent_enters_base={self.opponent_enters_base}, caught_energy={self.caught_energy!r}")
            + ("" if self.min_reward_area is None else f", min_reward_area={self.min_reward_area}")
            + ("" if self.observation == "thesis" else f", observation={self.observation!r}")
            + ")"
        )

    def check_param_values(self, params: EnvParams) -> EnvParams:
        """``params`` if their values are ones :meth:`make_params` accepts
        (:func:`jaxdc.dcg.param_values.check_param_values`)."""
        return check_param_values(params)

    def grid_shapes(self) -> tuple[dict[str, tuple[int, ...]], dict[str, tuple[int, ...]]]:
        """The state's grid-shaped fields (the items, the history planes); the parameters have none."""
        n = (self.grid_size, self.grid_size)
        return {}, {"items": n, "history": n + (self.history,)}

    def default_rules(self) -> bool:
        """Whether the four rule readings (``capture`` ... ``caught_energy``) are the defaults."""
        return (self.capture, self.safe_base, self.opponent_enters_base, self.caught_energy) == (
            CAPTURES[0], False, True, CAUGHT_ENERGIES[0])

    # -- parameters -------------------------------------------------------------------
    def make_params(self, energy: float = 15.0, max_steps: int = 100, chase_tie: str = "straight",
                    energy_range: Any = None, energy_tilt: float = 0.0) -> EnvParams:
        """Validated :class:`EnvParams`.

        Args:
          energy: the maximum (and initial) energy, > 0 (``inf`` allowed); 15
            in 5.5.1, 10 and 20 in Figs. 5.8-5.9.
          max_steps: the step cap (>= 1) that truncates an episode.
          chase_tie: how "moves towards" breaks ties, one of
            :data:`~jaxdc.dcg.opponents.CHASE_TIES`.
          energy_range: ``None`` (the thesis: every episode has ``energy``) or
            ``(low, high)``, whole numbers ``1 <= low <= high <= 2**24``: each
            episode's maximum energy is drawn uniformly among the integers of
            the range (beyond the thesis); ``energy`` is then not used.
          energy_tilt: with ``energy_range``, 0 (uniform) or a power-law tilt
            in ``[-8, 8]`` (:func:`jaxdc.core.energy.draw_max_energy`: a
            positive tilt weights the low budgets; beyond the thesis).
        """
        e = check_budget("energy", energy)
        check_int("max_steps", max_steps, 1, INT32_MAX)
        check_choice("chase_tie", chase_tie, CHASE_TIES)
        params = EnvParams(
            max_energy=jnp.float32(e),
            max_steps=jnp.int32(max_steps),
            chase_tie=jnp.int32(CHASE_TIES.index(chase_tie)),
        )
        tilt = check_energy_tilt(energy_tilt)
        if energy_range is None:
            if tilt != 0.0:
                raise ValueError(f"energy_tilt tilts the draw of energy_range and needs one, got energy_tilt={tilt:g} "
                                 "with energy_range=None (0 without a range)")
            return params
        low, high = check_energy_range(energy_range, MIN_RANGE_ENERGY)
        return dataclasses.replace(params, max_energy=jnp.float32(high),
                                   energy_range=jnp.asarray([low, high], jnp.float32),
                                   energy_tilt=None if tilt == 0.0 else jnp.float32(tilt))

    def reward_area_cells(self, size: int | None = None) -> np.ndarray:
        """Row-major flat indices of the cells that can hold an item (section 5.5.5, Fig. 5.10).

        The bottom-right ``size x size`` square (``size`` defaults to
        ``self.reward_area``; ``None`` there means the whole grid), base
        included only when it lies inside and ``items_on_base`` is true.
        """
        n = self.grid_size
        size = self.reward_area if size is None else size
        if size is None:
            size = n
        elif not is_int(size) or not 1 <= size <= n:
            raise ValueError(f"reward_area must be an int between 1 and grid_size ({n}), got {size!r}")
        r, c = np.divmod(np.arange(n * n), n)
        inside = (r >= n - size) & (c >= n - size)
        if not self.items_on_base:
            inside[0] = False
        return np.flatnonzero(inside).astype(np.int32)

    def _reward_area_table(self) -> tuple[jax.Array, jax.Array]:
        """``(table, counts)`` for sizes ``min_reward_area .. reward_area``: the cells of each square
        (:meth:`reward_area_cells`), padded to the largest, and how many each has."""
        assert self.min_reward_area is not None and self.reward_area is not None  # only built with both
        areas = [self.reward_area_cells(s) for s in range(self.min_reward_area, self.reward_area + 1)]
        table = np.zeros((len(areas), max(a.size for a in areas)), np.int32)
        for i, a in enumerate(areas):
            table[i, : a.size] = a
        return jnp.asarray(table), jnp.asarray([a.size for a in areas], jnp.int32)

    def max_energy_of(self, state: EnvState, params: EnvParams) -> jax.Array:
        """The episode's maximum energy: ``params.max_energy``, or the one it drew from ``params.energy_range``."""
        return params.max_energy if state.max_energy is None else state.max_energy

    # -- dynamics ---------------------------------------------------------------------
    def reset_env(self, key: jax.Array, params: EnvParams) -> tuple[jax.Array, EnvState]:
        """The initial state of section 5.3: collector in the base, random opponent, items and strategy."""
        n, cells = self.grid_size, self.grid_size**2
        budget = {}
        if params.energy_range is not None:  # its own stream: the rest draws as with a fixed energy
            budget["max_energy"] = draw_max_energy(jax.random.fold_in(key, ENERGY_STREAM), params.energy_range,
                                                  params.energy_tilt)
        k_items, k_opp, k_target, k_strat = jax.random.split(key, 4)
        if self.reward_area is None:
            items, _ = drop_units(k_items, self.total_reward, cells, 0 if self.items_on_base else 1)
        elif self.min_reward_area is not None:  # a size per episode, then the drop over its square
            k_size, k_drop = jax.random.split(k_items)
            table, counts = self._reward_area_table()
            size = uniform_index(k_size, (), counts.size)
            where = table[size][uniform_index(k_drop, (self.total_reward,), counts[size])]
            items = jnp.zeros(cells, jnp.float32).at[where].add(1.0)
        else:  # the reward area (section 5.5.5): the drop over its cells
            area = self.reward_area_cells()
            area_items, _ = drop_units(k_items, self.total_reward, area.size)
            items = jnp.zeros(cells, jnp.float32).at[area].set(area_items)
        if self.opponent_start == "not_base":
            start = 1 + uniform_index(k_opp, (), cells - 1)
        else:
            start = uniform_index(k_opp, (), cells)
        if self.patrol_target == "other":  # non-base cells other than the start, in row-major order
            off_base = start != 0
            t = 1 + uniform_index(k_target, (), cells - 1 - off_base.astype(jnp.int32))
            target = jnp.where(off_base & (t >= start), t + 1, t)
        else:
            target = 1 + uniform_index(k_target, (), cells - 1)
        home = grid.unflat_index(start, n)
        state = EnvState(
            pos=jnp.zeros(2, jnp.int32),
            energy=budget.get("max_energy", params.max_energy),
            items=items.reshape(n, n),
            opponent=OpponentState(pos=home, home=home, target=grid.unflat_index(target, n), phase=jnp.int32(0)),
            strategy=uniform_index(k_strat, (), len(self.strategies)),
            history=jnp.zeros((n, n, self.history), jnp.float32),
            time=jnp.int32(0),
            outcome=jnp.int32(RUNNING),
            ep_reward=jnp.float32(0.0),
            ep_energy=jnp.int32(0),
            **budget,
        )
        if self.history_fill == "first":
            plane = self.observed_agent_plane(state, params)
            state = dataclasses.replace(state, history=jnp.repeat(plane[..., None], self.history, axis=-1))
        return self.observe(state, params), state

    def opponent_move(self, key: jax.Array, state: EnvState, params: EnvParams) -> tuple[jax.Array, OpponentState]:
        """The opponent's action ``o_t`` and its new state (moved), by this episode's strategy."""
        branches = [
            lambda k, o, g, p, f=s.fn: tuple(jax.tree_util.tree_map(jnp.asarray, f(k, o, g, p)))
            for s in self._strategies
        ]
        action, opp = jax.lax.switch(state.strategy, branches, key, state.opponent, state, params)
        action = jnp.asarray(action, jnp.int32)
        pos = grid.move(state.opponent.pos, action, self.grid_size)
        if not self.opponent_enters_base:  # a move into the base becomes a stay
            blocked = jnp.all(pos == 0)
            pos = jnp.where(blocked, state.opponent.pos, pos)
            action = jnp.where(blocked, grid.STAY, action)
        return action, opp.replace(pos=pos)

    def step_env(self, key: jax.Array, state: EnvState, action: Any, params: EnvParams) -> Transition:
        """One transition of section 5.3, without auto-reset."""
        action, invalid = grid.clip_action(action)
        o_t, opp = self.opponent_move(key, state, params)
        caught_first = jnp.all(opp.pos == state.pos)  # (1) the opponent lands on the collector
        if self.safe_base:
            caught_first &= ~jnp.all(state.pos == 0)
        pos = jnp.where(caught_first, state.pos, grid.move(state.pos, action, self.grid_size))  # (2)
        caught_after = ~caught_first & jnp.all(pos == opp.pos)  # (3)
        if self.capture == "opponent_moves":
            caught_after = jnp.bool_(False)
        elif self.safe_base:
            caught_after &= ~jnp.all(pos == 0)
        collect = ~caught_first
        if not self.reward_when_caught:
            collect = collect & ~caught_after
        item = state.items[pos[0], pos[1]]
        reward = jnp.where(collect, item, 0.0)
        items = state.items.at[pos[0], pos[1]].set(jnp.where(collect, 0.0, item))
        in_base = jnp.all(pos == 0)  # (4)
        energy, out_of_energy = step_energy(state.energy, self.max_energy_of(state, params), in_base)
        used = energy_used(self.energy_metric, in_base, jnp.all(state.pos == 0))
        if self.caught_energy == "uncharged":  # the step ends at rule (1), before the energy rule
            energy = jnp.where(caught_first, state.energy, energy)
            used &= ~caught_first
        time = state.time + 1
        outcome = jnp.select(
            [caught_first | caught_after, out_of_energy, jnp.all(items <= 0), time >= params.max_steps],
            [CAUGHT, ENERGY, CLEARED, TRUNCATED],
            RUNNING,
        ).astype(jnp.int32)
        history = jnp.concatenate([self.observed_agent_plane(state, params)[..., None], state.history[..., :-1]],
                                  axis=-1)
        new_state = dataclasses.replace(
            state,
            pos=pos, energy=energy, items=items, opponent=opp, history=history, time=time, outcome=outcome,
            ep_reward=state.ep_reward + reward, ep_energy=state.ep_energy + used.astype(jnp.int32),
        )
        terminated, truncated, info = end_of_step(new_state, o_t, invalid)
        return self.observe(new_state, params), new_state, reward, terminated, truncated, info

    # -- pictures (outside jit; jaxdc.dcg.picture) ----------------------------------------
    def render_ansi(self, state: EnvState, params: EnvParams) -> str:
        """Text grid (:func:`jaxdc.dcg.picture.render_ansi`): ``C`` collector, ``O`` opponent, ``B`` base, items."""
        return picture.render_ansi(self, state, params)

    def scene(self, state: EnvState, params: EnvParams) -> Scene:
        """The layers of a frame (:func:`jaxdc.dcg.picture.scene`): items, collector, opponent, fog."""
        return picture.scene(self, state, params)


def end_of_step(state: Any, opponent_action: jax.Array, invalid: jax.Array) -> tuple[jax.Array, jax.Array, dict]:
    """``(terminated, truncated, info)`` after a step that led to ``state`` (a game's, or a team's with the same
    fields): terminated once the game is decided (its outcome is neither running nor the step cap's), truncated
    at the cap; ``info`` holds the outcome, the opponent's action, the episode's strategy, its running totals and
    whether the action was clipped. Shared by :class:`DCG` and :class:`jaxdc.dcg.team.DCGTeam`."""
    outcome = state.outcome
    info = {"outcome": outcome, "opponent_action": opponent_action, "strategy": state.strategy,
            "episode_reward": state.ep_reward, "episode_energy": state.ep_energy, "episode_steps": state.time,
            "invalid_action": invalid}
    return (outcome != RUNNING) & (outcome != TRUNCATED), outcome == TRUNCATED, info
