"""A centralised critic for the team trainer of :mod:`jaxdc.agents.a2c`: MAPPO (beyond the thesis, issue 29).

The thesis' conclusion to chapter 5 proposes several cooperating collectors; :func:`jaxdc.agents.a2c.make_train`
trains them on a team environment (``action_shape == (k,)``) as ``k`` rows of one batch sharing one network. By
default each row's value comes from that network's own value head on the collector's own observation
(shared-parameter IPPO). With ``make_train(..., critic=...)`` the same trainer becomes MAPPO (Yu et al. 2022,
"The Surprising Effectiveness of PPO in Cooperative Multi-Agent Games"): the value of the n-step/GAE returns,
of the truncation bootstrap and of the value loss comes from a separate network, the centralised critic
(e.g. :class:`jaxdc.nets.critic.WorldCritic`), reading the environment's world state
(``env.world_state(state, params)``, the hook of :class:`jaxdc.dcg.team.DCGTeam`), while every actor still acts
on its own observation. The actor keeps the collector's network (VNN, IMNN, EMNN, OMN + CoNN) with its
auxiliary head; its own value head is not used (it gets no gradient).

**One value per team state**, broadcast to the ``k`` rows of its environment: every collector learns from the
team reward, so the state's value is the same for each of them (an agent id in the critic's input would be an
input it has to learn to ignore), and the critic runs on ``B`` states, not ``B * k`` rows, in the rollout.

**Where its parameters live**: under the top-level name :data:`CRITIC` beside the actor's in the one trained
tree (``{"params": {..actor.., "central_critic": {..}}}``): one Adam, one checkpoint, exact resume, and the
actor's ``apply`` reads the tree unchanged (flax ignores the extra entry). :func:`actor_params` drops it: a
shipped or exported network is the actor alone, and a loader strips the critic of a run folder's parameters.

**The final value of a truncated episode** is the critic's on the world state *before* the auto-reset, which the
environment's step gives as ``info["world_state"]`` (as ``info["final_observation"]`` for the observations).
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp

#: The top-level parameter name of the centralised critic inside the trained parameter tree.
CRITIC = "central_critic"
#: ``fold_in`` constant of the critic's initial key (the run's key): the actor, the games and the training key
#: start exactly as without a critic.
CRITIC_KEY = 0x43524954


def actor_params(params: Any) -> Any:
    """``params`` without the centralised critic's entry (the actor alone, what plays); unchanged without one."""
    if isinstance(params, dict) and isinstance(params.get("params"), dict) and CRITIC in params["params"]:
        return {**params, "params": {k: v for k, v in params["params"].items() if k != CRITIC}}
    return params


class CentralCritic(NamedTuple):
    """A critic network ``net`` (``world [B, ...] -> value [B]``) on the world states of ``env`` with
    ``env_params``, for a team of ``agents`` rows per environment (module docs). Build it with :meth:`of`."""

    net: Any
    env: Any
    env_params: Any
    agents: int

    @classmethod
    def of(cls, net: Any, env: Any, env_params: Any, agents: int | None) -> CentralCritic:
        """Checked outside jit: ``env`` a team environment (``agents`` rows each) with a ``world_state`` hook and
        ``net`` a flax module; each failure a ``ValueError`` (``TypeError``) naming ``critic``."""
        if agents is None:
            raise ValueError(f"critic: a centralised critic reads a team's world state; {type(env).__name__} is a "
                             "one-agent environment (no action_shape (k,)): train it without critic")
        if not callable(getattr(env, "world_state", None)):
            raise ValueError(f"critic: {type(env).__name__} has no world_state(state, params) for the critic")
        if not callable(getattr(net, "init", None)) or not callable(getattr(net, "apply", None)):
            raise TypeError(f"critic must be a flax module (world [B, ...] -> value [B]), got {net!r}")
        return cls(net, env, env_params, agents)

    def world(self, env_state: Any) -> jax.Array:
        """The world states ``[B, ...]`` of ``B`` environment states."""
        return jax.vmap(self.env.world_state, in_axes=(0, None))(env_state, self.env_params)

    def init(self, key: jax.Array, env_state: Any, actor: Any) -> Any:
        """The trained tree: the actor's parameters ``actor`` with fresh critic parameters (from
        ``fold_in(key, CRITIC_KEY)``, initialised on the world states of ``env_state``) under :data:`CRITIC`.
        An actor with a parameter of that name is refused (``ValueError``; a static structure, so at trace time)."""
        if CRITIC in actor["params"]:
            raise ValueError(f"critic: the actor already has parameters named {CRITIC!r}")
        inner = self.net.init(jax.random.fold_in(key, CRITIC_KEY), self.world(env_state))["params"]
        return {**actor, "params": {**actor["params"], CRITIC: inner}}

    def value(self, params: Any, world: jax.Array) -> jax.Array:
        """``V(world) [B]`` with the critic's entry of the trained tree ``params``."""
        return self.net.apply({"params": params["params"][CRITIC]}, world)

    def row_values(self, params: Any, world: jax.Array) -> jax.Array:
        """``[B * k]``: each environment's value on each of its ``k`` rows (the team's rows, in order)."""
        return jnp.repeat(self.value(params, world), self.agents, axis=0)

    def apply_with(self, apply_fn: Callable, world: jax.Array) -> Callable:
        """``apply_fn`` (the actor's ``(params, obs, heuristics) -> (logits, value, *aux)``) with the value
        replaced by the critic's on ``world`` (one world state per row), for the loss."""

        def apply(params, obs, heuristics):
            logits, _, *aux = apply_fn(params, obs, heuristics)
            return (logits, self.value(params, world), *aux)

        return apply
