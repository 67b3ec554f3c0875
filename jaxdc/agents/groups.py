"""Several environments in one training batch (beyond the thesis): :class:`EnvGroup` and the checks of
:func:`jaxdc.agents.a2c.make_train`'s ``extra_envs`` (e.g. the DCP on several grid sizes for a network whose body
pools over the cells; docs/generalisation.md, "Several grid sizes")."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Callable, NamedTuple

import jax

from jaxdc.agents.common import Network, RunConfig, check_mask, first_batch, heuristics_fn, team_size
from jaxdc.core.env import Environment

__all__ = ["EnvGroup", "check_extra_envs"]


class EnvGroup(NamedTuple):
    """One more environment of a trainer's batch (``make_train(..., extra_envs=...)``): an environment (e.g. the
    DCP on another grid size), its params and its heuristics (``None``: as :func:`~jaxdc.agents.common.heuristics_fn`
    gives for a network without them)."""

    env: Any
    env_params: Any
    heuristics: Callable | None = None


def check_extra_envs(extra_envs: Sequence[EnvGroup], config: RunConfig, minibatches: int, env: Environment,
                     env_params: Any, net: Network, heuristics: Callable, agents: int | None, critic: Any,
                     mask: Callable | None) -> tuple[EnvGroup, ...]:
    """``extra_envs`` of :func:`jaxdc.agents.a2c.make_train` checked outside jit, each with its heuristics resolved:
    one agent and no critic; ``num_envs`` and each minibatch split evenly over the groups; and the network,
    initialised on the first environment, must apply to each one's observations (e.g. a body pooled over the cells
    on another grid size). A ``ValueError`` names ``extra_envs`` and what to change."""
    if isinstance(extra_envs, EnvGroup) or not isinstance(extra_envs, (tuple, list)):
        raise TypeError(f"extra_envs must be a sequence of EnvGroup(env, env_params, heuristics), "
                        f"got {extra_envs!r}")
    if not extra_envs:
        return ()
    for i, grp in enumerate(extra_envs):
        if not isinstance(grp, EnvGroup):
            raise TypeError(f"extra_envs[{i}] must be an EnvGroup(env, env_params, heuristics), got {grp!r}")
    if agents is not None or critic is not None:
        raise ValueError("extra_envs: several environments in one batch train one agent with its own value; "
                         f"{type(env).__name__} is a team of {agents}" if agents is not None else
                         "extra_envs: several environments in one batch are not for a centralised critic")
    g_count = 1 + len(extra_envs)
    if config.num_envs % g_count:
        raise ValueError(f"num_envs ({config.num_envs}) must be a multiple of the {g_count} environments "
                         f"(1 + len(extra_envs)), so that each gets the same share")
    if (config.batch_size // g_count) % minibatches or config.batch_size % g_count:
        raise ValueError(f"minibatches ({minibatches}) must divide each environment's share of the rollout "
                         f"(num_envs * t_max / {g_count} = {config.batch_size / g_count:g})")
    params = jax.eval_shape(lambda k: first_batch(k, env, env_params, net, heuristics, 1)[0], jax.random.PRNGKey(0))
    out = []
    for i, grp in enumerate(extra_envs):
        if team_size(grp.env) is not None:
            raise ValueError(f"extra_envs[{i}]: {type(grp.env).__name__} is a team; the groups are one-agent")
        h = heuristics_fn(net, grp.heuristics)
        if mask is not None:
            check_mask(mask, grp.env, grp.env_params, net, None)
        try:
            obs, state = jax.eval_shape(lambda k, g=grp: jax.vmap(g.env.reset, in_axes=(0, None))(
                jax.random.split(k, 1), g.env_params), jax.random.PRNGKey(0))
            jax.eval_shape(net.apply, params, obs, jax.eval_shape(h, state))
        except Exception as e:  # noqa: BLE001 - flax's shape errors are not ValueErrors; each is reported as one
            raise ValueError(f"extra_envs[{i}]: {type(net).__name__}, initialised on the first environment's "
                             f"observations, does not apply to this one's ({e}); a network that plays several "
                             "grid sizes needs a body pooled over the cells (body_pool='mean_max')") from None
        out.append(EnvGroup(grp.env, grp.env_params, h))
    return tuple(out)
