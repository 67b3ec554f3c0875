"""The team Data-collection Game: ``k`` collectors against ``m`` opponents (issue 29).

The thesis' conclusion to chapter 5 names the next step: "generalizing the game to one with multiple
data-collecting agents, so that the agents can cooperate to collect data more efficiently under the
influence of the opponent". :class:`DCGTeam` is that game on the rules of section 5.3 (settings of
5.5.1), applied to everyone at once; docs/dcg.md ("The team game") and the shared rules in
docs/ambiguities.md give every reading the thesis does not fix. With ``collectors=1, opponents=1``
(and ``teammates=False``, the default there) it is :class:`jaxdc.dcg.env.DCG` exactly: the same reset
from the same key, the same transitions, the same observations.

One transition, in the order of section 5.3:

1. every opponent moves from the pre-step state by its own strategy, chasing its target
   (:mod:`jaxdc.dcg.team.targeting`);
2. an active collector on whose cell an opponent lands is caught and does not move (rule 1);
3. every other active collector moves (clipped per axis) and collects the item in its new cell; when
   several end on one item cell, the lowest index takes it (its per-collector reward), and the team
   reward counts it once (rule 2);
4. a collector that ends on an opponent's cell is caught (rule 3; the item still counts with
   ``reward_when_caught=True``);
5. each collector active at the start of the step refills in the base or spends one unit, and is
   disabled at 0 (rule 4);
6. a disabled collector stays put, is never a target, collects nothing, keeps its energy, and its
   actions are ignored (:meth:`DCGTeam.get_avail_actions` offers it only ``stay``).

The team reward is the items collected by anyone; the episode terminates when every collector is
disabled or every item is collected, and is truncated at ``max_steps``.

``info`` holds the DCG's keys, the per-collector ``collector_rewards`` and ``collector_outcomes`` ``[k]``, and
``world_state``: :meth:`~jaxdc.dcg.team.observation.TeamObservation.world_state` of the state the step reached,
before an auto-reset (a centralised critic's bootstrap of a truncated episode, :mod:`jaxdc.agents.centralised`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp

from jaxdc.core import grid, spaces
from jaxdc.core.energy import energy_used, step_energy
from jaxdc.core.env import Environment, Transition
from jaxdc.core.scene import Scene
from jaxdc.core.validate import check_bool, check_choice, check_int
from jaxdc.dcg.env import DCG, end_of_step
from jaxdc.dcg.param_values import check_param_values
from jaxdc.dcg.team import picture
from jaxdc.dcg.team.observation import TeamObservation
from jaxdc.dcg.team.state import FOG_TARGETS, MAX_COLLECTORS, MAX_OPPONENTS, TARGET_TIES, TeamState, collector_view
from jaxdc.dcg.team.targeting import opponents_move
from jaxdc.dcg.types import CAUGHT, CLEARED, ENERGY, OUTCOMES, RUNNING, TRUNCATED, EnvParams

#: The DCG's settings read through the team game (``env.strategies``, ``env.history``, ...).
DCG_SETTINGS = ("total_reward", "strategies", "_strategies", "history", "obs_history", "history_fill",
                "items_on_base", "opponent_start", "patrol_target", "reward_when_caught", "energy_metric",
                "reward_area", "min_reward_area", "capture", "safe_base", "opponent_enters_base", "caught_energy",
                "observation")


class DCGTeam(TeamObservation, Environment[TeamState, EnvParams]):
    """``k`` collectors and ``m`` opponents (see the module docs), stacked: observations ``[k, N, N, C]``,
    actions ``[k]``, one team reward; gymnax-style ``step`` with auto-reset (:class:`~jaxdc.core.env.Environment`).

    Args:
      collectors: ``k``, 1 .. :data:`~jaxdc.dcg.team.state.MAX_COLLECTORS`.
      opponents: ``m``, 1 .. :data:`~jaxdc.dcg.team.state.MAX_OPPONENTS`; each draws its start, patrol end and
        strategy at reset (the first as the DCG does, opponent ``j`` from ``fold_in(key, j)``).
      teammates: whether each observation has the teammates plane after ``M^agent``; default: ``k > 1``
        (``False`` gives every collector the one-collector observation, for copies of a DCG network).
      fog_target: whom a fog strategy chases, one of :data:`~jaxdc.dcg.team.state.FOG_TARGETS`.
      target_tie: how a chaser picks among equally near collectors, one of
        :data:`~jaxdc.dcg.team.state.TARGET_TIES`.
      **options: every option of :class:`jaxdc.dcg.env.DCG` (grid size, strategies, rule readings, history,
        observation, ...), with the same meaning, applied per collector and per opponent.

    The parameters are the DCG's (:meth:`make_params`: energy, step cap, chase tie, energy range).
    """

    outcomes: tuple[str, ...] = OUTCOMES
    state_type = TeamState
    params_type = EnvParams

    def __init__(self, collectors: int = 2, opponents: int = 1, teammates: bool | None = None,
                 fog_target: str = "visible", target_tie: str = "index", **options: Any) -> None:
        self.collectors = check_int("collectors", collectors, 1, MAX_COLLECTORS)
        self.opponents = check_int("opponents", opponents, 1, MAX_OPPONENTS)
        self.teammates = self.collectors > 1 if teammates is None else check_bool("teammates", teammates)
        self.fog_target = check_choice("fog_target", fog_target, FOG_TARGETS)
        self.target_tie = check_choice("target_tie", target_tie, TARGET_TIES)
        #: The one-collector game whose rules, strategies and observation the team reuses (it checks the options).
        self.single = DCG(**options)
        self.grid_size = self.single.grid_size
        self.action_shape = (self.collectors,)

    def __getattr__(self, name: str) -> Any:
        if name in DCG_SETTINGS and "single" in self.__dict__:
            return getattr(self.single, name)
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")

    def _config(self) -> tuple:
        return (self.collectors, self.opponents, self.teammates, self.fog_target, self.target_tie) + \
            self.single._config()

    def __repr__(self) -> str:
        return (f"DCGTeam(collectors={self.collectors}, opponents={self.opponents}, teammates={self.teammates}, "
                f"fog_target={self.fog_target!r}, target_tie={self.target_tie!r}, game={self.single!r})")

    def check_param_values(self, params: EnvParams) -> EnvParams:
        """``params`` if their values are ones :meth:`make_params` accepts (the one-collector game's
        :func:`jaxdc.dcg.param_values.check_param_values`)."""
        return check_param_values(params)

    def grid_shapes(self) -> tuple[dict[str, tuple[int, ...]], dict[str, tuple[int, ...]]]:
        """The state's shaped fields: the DCG's grid fields, the collectors' ``[k]`` and the opponents' ``[m]``."""
        n, k = (self.grid_size, self.grid_size), self.collectors
        return {}, {"items": n, "history": (k,) + n + (self.single.history,), "pos": (k, 2), "energy": (k,),
                    "collector_outcome": (k,), "strategy": (self.opponents,)}

    def action_space(self, params: EnvParams | None = None) -> spaces.Discrete:
        """One of the 9 grid actions per collector: ``Discrete(9, shape=(k,))``."""
        return spaces.Discrete(self.num_actions, shape=(self.collectors,))

    def make_params(self, *args: Any, **kwargs: Any) -> EnvParams:
        """The DCG's parameters (:meth:`jaxdc.dcg.env.DCG.make_params`, same arguments and checks)."""
        return self.single.make_params(*args, **kwargs)

    def max_energy_of(self, state: TeamState, params: EnvParams) -> jax.Array:
        """The episode's maximum energy (one for the team)."""
        return params.max_energy if state.max_energy is None else state.max_energy

    def get_avail_actions(self, state: TeamState) -> jax.Array:
        """``[k, 9]`` bool: every action for an active collector, only ``stay`` for a disabled one (its actions are
        ignored anyway)."""
        stay = jnp.arange(self.num_actions) == grid.STAY
        return state.active[:, None] | stay[None, :]

    # -- dynamics ---------------------------------------------------------------------------
    def reset_env(self, key: jax.Array, params: EnvParams) -> tuple[jax.Array, TeamState]:
        """Items, the first opponent and its strategy as :meth:`DCG.reset_env` draws them from ``key``; opponent
        ``j >= 1`` as the DCG draws its opponent from ``fold_in(key, j)``; every collector in the base, full."""
        k, n = self.collectors, self.grid_size
        _, first = self.single.reset_env(key, params)
        opp, strategy = jax.tree_util.tree_map(lambda x: x[None], (first.opponent, first.strategy))
        if self.opponents > 1:
            _, more = jax.vmap(lambda j: self.single.reset_env(jax.random.fold_in(key, j), params))(
                jnp.arange(1, self.opponents))
            opp, strategy = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a, b]), (opp, strategy),
                                                   (more.opponent, more.strategy))
        state = TeamState(
            pos=jnp.zeros((k, 2), jnp.int32), energy=jnp.full((k,), first.energy, jnp.float32),
            collector_outcome=jnp.full((k,), RUNNING, jnp.int32), items=first.items, opponent=opp,
            strategy=strategy, history=jnp.zeros((k, n, n, self.single.history), jnp.float32), time=first.time,
            outcome=first.outcome, ep_reward=first.ep_reward, ep_energy=first.ep_energy,
            max_energy=first.max_energy,
        )
        if self.single.history_fill == "first":
            planes = self.agent_planes(state, params)
            state = dataclasses.replace(state, history=jnp.repeat(planes[..., None], self.single.history, axis=-1))
        return self.observe(state, params), state

    def _on_opponent(self, pos: jax.Array, opp_pos: jax.Array) -> jax.Array:
        """``[k]``: whether each collector cell holds an opponent."""
        return jnp.any(jnp.all(pos[:, None, :] == opp_pos[None, :, :], axis=-1), axis=1)

    def step_env(self, key: jax.Array, state: TeamState, action: Any, params: EnvParams) -> Transition:
        """One transition (the module docs), without auto-reset."""
        g = self.single
        actions, invalid = grid.clip_action(jnp.asarray(action))
        active = state.active
        o_t, opp = opponents_move(self, key, state, params)
        was_in_base = jnp.all(state.pos == 0, axis=-1)
        caught_first = active & self._on_opponent(state.pos, opp.pos)  # (1)
        if g.safe_base:
            caught_first &= ~was_in_base
        moving = active & ~caught_first  # (2)
        pos = jnp.where(moving[:, None], grid.move(state.pos, actions, self.grid_size), state.pos)
        caught_after = moving & self._on_opponent(pos, opp.pos)  # (3)
        if g.capture == "opponent_moves":
            caught_after = jnp.zeros_like(caught_after)
        elif g.safe_base:
            caught_after &= ~jnp.all(pos == 0, axis=-1)
        collect = moving if g.reward_when_caught else moving & ~caught_after
        same = jnp.all(pos[:, None, :] == pos[None, :, :], axis=-1)
        earlier = jnp.tril(jnp.ones((self.collectors,) * 2, bool), -1)  # [i, j]: j < i
        takes = collect & ~jnp.any(same & earlier & collect[None, :], axis=1)  # the lowest index takes the item
        item = state.items[pos[:, 0], pos[:, 1]]
        rewards = jnp.where(takes, item, 0.0)
        items = state.items.at[pos[:, 0], pos[:, 1]].multiply(jnp.where(takes, 0.0, 1.0))
        reward = jnp.sum(rewards)
        in_base = jnp.all(pos == 0, axis=-1)  # (4)
        energy, out_of_energy = step_energy(state.energy, self.max_energy_of(state, params), in_base)
        used = jnp.broadcast_to(energy_used(g.energy_metric, in_base, was_in_base), (self.collectors,))
        if g.caught_energy == "uncharged":  # the step ends at rule (1), before the energy rule
            energy = jnp.where(caught_first, state.energy, energy)
            used = used & ~caught_first
        energy = jnp.where(active, energy, state.energy)  # (6) a disabled collector's energy is frozen
        caught = caught_first | caught_after
        collector_outcome = jnp.where(
            active, jnp.select([caught, out_of_energy], [CAUGHT, ENERGY], RUNNING), state.collector_outcome
        ).astype(jnp.int32)
        newly = active & (collector_outcome != RUNNING)
        all_disabled = jnp.all(collector_outcome != RUNNING)
        time = state.time + 1
        outcome = jnp.select(
            [all_disabled & jnp.any(newly & caught), all_disabled, jnp.all(items <= 0), time >= params.max_steps],
            [CAUGHT, ENERGY, CLEARED, TRUNCATED],
            RUNNING,
        ).astype(jnp.int32)
        planes = self.agent_planes(state, params)
        history = jnp.concatenate([planes[..., None], state.history[..., :-1]], axis=-1)
        ep_reward = state.ep_reward + reward
        ep_energy = state.ep_energy + jnp.sum((used & active).astype(jnp.int32))
        new_state = dataclasses.replace(state, pos=pos, energy=energy, collector_outcome=collector_outcome, items=items,
                                  opponent=opp, history=history, time=time, outcome=outcome, ep_reward=ep_reward,
                                  ep_energy=ep_energy)
        terminated, truncated, info = end_of_step(new_state, o_t, invalid)
        info.update(collector_rewards=rewards, collector_outcomes=collector_outcome,
                    world_state=self.world_state(new_state, params))
        return self.observe(new_state, params), new_state, reward, terminated, truncated, info

    def view(self, state: TeamState, collector: int, opponent: int = 0) -> Any:
        """Collector ``collector``'s one-collector DCG state facing opponent ``opponent``
        (:func:`jaxdc.dcg.team.state.collector_view`)."""
        return collector_view(state, collector, opponent)

    # -- pictures (outside jit; jaxdc.dcg.team.picture) -------------------------------------------
    def render_ansi(self, state: TeamState, params: EnvParams) -> str:
        """Text grid (:func:`jaxdc.dcg.team.picture.render_ansi`): collectors by number, opponents ``O``."""
        return picture.render_ansi(self, state, params)

    def scene(self, state: TeamState, params: EnvParams) -> Scene:
        """The layers of a frame (:func:`jaxdc.dcg.team.picture.scene`): every collector and opponent."""
        return picture.scene(self, state, params)
