"""A JaxMARL-style adapter for the team DCG (:class:`jaxdc.dcg.team.env.DCGTeam`, issue 29).

JaxMARL (the JAX multi-agent suite) keys everything by agent name. :class:`JaxMARLTeam` gives the
team game that API without importing ``jaxmarl`` (an optional extra, ``pip install jaxdc[marl]``):

* ``agents``: ``["agent_0", ..., "agent_{k-1}"]`` (collector ``i`` is ``agent_i``), ``num_agents``;
* ``reset(key) -> (obs, state)`` and ``step(key, state, actions, reset_state=None) -> (obs, state,
  rewards, dones, infos)`` with JaxMARL's auto-reset (``dones["__all__"]``), ``step_env`` without it,
  ``get_obs(state)``; the state is the game's :class:`~jaxdc.dcg.team.state.TeamState`;
* observations, actions and rewards are dicts by agent; each agent's observation is its DCG-style
  ``[N, N, C]`` observation; with ``world_state=True`` (default) the observation dict also holds
  ``"world_state"`` (the centralised critic's input, as JaxMARL's SMAX does for its MAPPO baseline), and
  :meth:`JaxMARLTeam.get_world_state` returns it;
* rewards: ``reward="team"`` (default) gives the team reward to every agent, as JaxMARL's cooperative
  environments give their shared reward; ``"collector"`` gives each agent its own items;
* ``dones[agent]``: the collector is disabled or the episode ended; ``dones["__all__"]``: the episode
  ended (terminated or truncated);
* ``infos``: every value is ``[k]`` (JaxMARL's training loops reshape infos to ``num_actors``): the
  per-collector ``collector_rewards``, ``collector_outcomes``, ``invalid_action``, and the game's scalar
  ``outcome``, ``episode_reward``, ``episode_energy``, ``episode_steps`` repeated per agent;
* ``get_avail_actions(state)``: ``{agent: [9] bool}`` (only ``stay`` for a disabled collector);
* ``observation_space(agent)`` / ``action_space(agent)`` (jaxdc's gymnax-style spaces: ``Box``,
  ``Discrete(9)``), ``observation_spaces`` / ``action_spaces`` dicts, ``agent_classes``.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxdc.core import spaces
from jaxdc.core.env import tree_select
from jaxdc.core.validate import check_bool, check_choice
from jaxdc.dcg.team.env import DCGTeam
from jaxdc.dcg.team.state import TeamState

#: Who gets which reward: ``"team"`` -- the team reward to every agent; ``"collector"`` -- each its own items.
REWARDS = ("team", "collector")
#: The info keys (each ``[k]``) the adapter passes on.
INFO_KEYS = ("collector_rewards", "collector_outcomes", "invalid_action", "outcome", "episode_reward",
             "episode_energy", "episode_steps")

Dict = dict[str, Any]


class JaxMARLTeam:
    """The team DCG with JaxMARL's ``MultiAgentEnv`` API (see the module docs).

    Args:
      env: a :class:`~jaxdc.dcg.team.env.DCGTeam`.
      params: its parameters (default: ``env.default_params``), fixed for the adapter (JaxMARL's ``reset``
        takes only a key).
      reward: one of :data:`REWARDS`.
      world_state: whether the observation dict holds ``"world_state"``.
    """

    def __init__(self, env: DCGTeam, params: Any = None, reward: str = "team", world_state: bool = True) -> None:
        if not isinstance(env, DCGTeam):
            raise TypeError(f"env must be a DCGTeam, got {type(env).__name__}")
        self.env = env
        # values too (energy > 0, max_steps >= 1, ...): Environment.check_param_values
        self.params = env.check_param_values(env.check_params(env.default_params if params is None else params))
        self.reward = check_choice("reward", reward, REWARDS)
        self.world_state = check_bool("world_state", world_state)
        self.num_agents = env.collectors
        self.agents = [f"agent_{i}" for i in range(self.num_agents)]
        low, high = env.observation_bounds(self.params)
        obs_space = spaces.Box(low[0], high[0], env.observation_shape(self.params)[1:], jnp.float32)
        self.observation_spaces = {a: obs_space for a in self.agents}
        self.action_spaces = {a: spaces.Discrete(env.num_actions) for a in self.agents}

    @property
    def name(self) -> str:
        return f"jaxdc/{self.env.name}"

    @property
    def agent_classes(self) -> dict[str, list[str]]:
        """One class: every agent is a collector."""
        return {"collector": list(self.agents)}

    def observation_space(self, agent: str) -> spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Discrete:
        return self.action_spaces[agent]

    def world_state_space(self) -> spaces.Box:
        """The bounds of :meth:`get_world_state` (items, energies, opponents, budget)."""
        e = self.env
        high = max(float(e.single.total_reward), float(e.observation_bounds(self.params)[1].max()))
        return spaces.Box(-1.0, high, e.world_state_shape(), jnp.float32)

    # -- JaxMARL's functions -------------------------------------------------------------------
    def get_obs(self, state: TeamState) -> Dict:
        return self._obs(self.env.observe(state, self.params), state)

    def _obs(self, stacked: jax.Array, state: TeamState) -> Dict:
        obs = {a: stacked[i] for i, a in enumerate(self.agents)}
        if self.world_state:
            obs["world_state"] = self.get_world_state(state)
        return obs

    def get_world_state(self, state: TeamState) -> jax.Array:
        """The centralised critic's input (:meth:`~jaxdc.dcg.team.observation.TeamObservation.world_state`)."""
        return self.env.world_state(state, self.params)

    def get_avail_actions(self, state: TeamState) -> Dict:
        avail = self.env.get_avail_actions(state)
        return {a: avail[i] for i, a in enumerate(self.agents)}

    def reset(self, key: jax.Array) -> tuple[Dict, TeamState]:
        obs, state = self.env.reset(key, self.params)
        return self._obs(obs, state), state

    def _actions(self, actions: Dict) -> jax.Array:
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ValueError(f"actions must hold one action per agent {self.agents}; missing {missing}")
        return jnp.stack([jnp.asarray(actions[a]) for a in self.agents])

    def _outputs(self, stacked: jax.Array, state: TeamState, reward: jax.Array, done: jax.Array,
                 info: dict[str, Any]) -> tuple[Dict, TeamState, Dict, Dict, Dict]:
        k = self.num_agents
        per = info["collector_rewards"] if self.reward == "collector" else jnp.broadcast_to(reward, (k,))
        rewards = {a: per[i] for i, a in enumerate(self.agents)}
        agent_done = (info["collector_outcomes"] != 0) | done
        dones = {a: agent_done[i] for i, a in enumerate(self.agents)}
        dones["__all__"] = done
        infos = {key: jnp.broadcast_to(info[key], (k,)) for key in INFO_KEYS}
        return self._obs(stacked, state), state, rewards, dones, infos

    def step_env(self, key: jax.Array, state: TeamState, actions: Dict) -> tuple[Dict, TeamState, Dict, Dict, Dict]:
        """One transition without auto-reset."""
        obs, state, reward, term, trunc, info = self.env.step_env(key, state, self._actions(actions), self.params)
        return self._outputs(obs, state, reward, term | trunc, info)

    def step(self, key: jax.Array, state: TeamState, actions: Dict,
             reset_state: TeamState | None = None) -> tuple[Dict, TeamState, Dict, Dict, Dict]:
        """One transition; when the episode ends, the next episode's first observation and state (a fresh reset,
        or ``reset_state`` when given), as JaxMARL's ``MultiAgentEnv.step``."""
        if reset_state is None:
            obs, state, reward, term, trunc, info = self.env.step(key, state, self._actions(actions), self.params)
            return self._outputs(obs, state, reward, term | trunc, info)
        obs_st, state_st, reward, term, trunc, info = self.env.step_env(key, state, self._actions(actions),
                                                                       self.params)
        done = term | trunc
        obs, state = tree_select(done, (self.env.observe(reset_state, self.params), reset_state), (obs_st, state_st))
        return self._outputs(obs, state, reward, done, info)
