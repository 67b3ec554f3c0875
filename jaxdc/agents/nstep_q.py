"""Synchronous n-step Q-learning for EQN (section 4.5.5; Asynchronous n-step Q-learning of [25]).

The thesis trains EQN (Fig. 4.4) with the asynchronous n-step Q-learning of
[25] and evaluates it epsilon-greedily with epsilon = 0.05. Here, as for
A2C, ``num_envs`` environments step in lock-step instead of threads:

1. every environment acts ``t_max`` steps epsilon-greedily on ``Q(s, .; theta)``;
   epsilon falls linearly from ``eps_start`` to ``eps_end`` over the first
   ``eps_fraction`` of the run (our choice; [25] samples a final epsilon per
   thread);
2. n-step targets as in Algorithm 10, bootstrapped with the *target network*:
   ``R_T = max_a Q(s_T, a; theta^-)``, 0 after a terminal state, and
   ``max_a Q(last state, a; theta^-)`` after a truncation;
3. one Adam step on the Huber loss of ``R_t - Q(s_t, a_t; theta)`` (DQN's
   error clipping [23, 24], which EQN is inspired by);
4. ``theta^- <- theta`` every ``target_every`` environment steps (40,000 in [25]).

Learning rate, its linear annealing, Adam's betas, ``gamma`` and ``t_max`` are
the settings A2C has too (:class:`jaxdc.agents.common.RunConfig`, which both
configs extend); :class:`QConfig` adds only exploration and the target network.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable

import jax
import jax.numpy as jnp
import optax
from flax import struct

from jaxdc.agents.common import (
    Network,
    RunConfig,
    Trainer,
    Transition,
    check_network,
    first_batch,
    heuristics_fn,
    huber,
    make_optimizer_from,
    masked_logits,
    nstep_returns,
)
from jaxdc.core.env import Environment, tree_select
from jaxdc.core.validate import INT32_MAX, check_float, is_int

#: Epsilon of the evaluation policy (section 4.5.5).
EVAL_EPSILON = 0.05


@dataclasses.dataclass(frozen=True)
class QConfig(RunConfig):
    """The shared settings of :class:`~jaxdc.agents.common.RunConfig`, exploration and the target network.

    Attributes:
      eps_start, eps_end: epsilon of the behaviour policy at the start and after ``eps_fraction`` of the run.
      eps_fraction: share of the run over which epsilon falls linearly.
      target_every: environment steps between copies ``theta^- <- theta`` (40,000 in [25]).
    """

    eps_start: float = 1.0
    eps_end: float = 0.05
    eps_fraction: float = 0.25
    target_every: int = 40_000

    def __post_init__(self):
        super().__post_init__()
        for name in ("eps_start", "eps_end"):
            check_float(name, getattr(self, name), low=0.0, high=1.0)
        check_float("eps_fraction", self.eps_fraction, low=0.0, high=1.0, low_open=True)
        if not is_int(self.target_every, numpy=False) or not 1 <= self.target_every <= INT32_MAX:
            raise ValueError(f"target_every must be an int >= 1 (environment steps), got {self.target_every!r}")

    @property
    def target_period(self) -> int:
        """Updates between target-network copies (at least 1)."""
        return max(1, self.target_every // self.batch_size)

    def epsilon(self, update: Any) -> jax.Array:
        """Exploration epsilon at ``update`` (jittable)."""
        frac = jnp.clip(update / max(1.0, self.eps_fraction * self.num_updates), 0.0, 1.0)
        return self.eps_start + frac * (self.eps_end - self.eps_start)


@struct.dataclass
class QTrainState:
    """Everything an n-step Q run depends on, with the target network's parameters."""

    params: Any
    target_params: Any
    opt_state: Any
    env_state: Any
    obs: jax.Array
    key: jax.Array
    update: jax.Array


def epsilon_greedy(key: jax.Array, q: jax.Array, epsilon: Any, allowed: jax.Array | None = None) -> jax.Array:
    """Argmax of ``q [..., A]``, or a uniform action with probability ``epsilon``; with ``allowed`` (bool
    ``[..., A]``, an action mask) both among the allowed actions only."""
    k_explore, k_action = jax.random.split(key)
    if allowed is None:
        random_action = jax.random.randint(k_action, q.shape[:-1], 0, q.shape[-1])
    else:
        random_action = jax.random.categorical(k_action, masked_logits(jnp.zeros(q.shape, jnp.float32), allowed))
    explore = jax.random.uniform(k_explore, q.shape[:-1]) < epsilon
    return jnp.where(explore, random_action, jnp.argmax(masked_logits(q, allowed), axis=-1)).astype(jnp.int32)


def q_loss(params: Any, apply_fn: Callable, obs: jax.Array, heuristics: jax.Array, actions: jax.Array,
           returns: jax.Array) -> tuple[jax.Array, dict[str, jax.Array]]:
    """Mean Huber loss of ``R - Q(s, a)``."""
    q = apply_fn(params, obs, heuristics)
    q_a = jnp.take_along_axis(q, actions[:, None], axis=-1)[:, 0]
    loss = jnp.mean(huber(returns - q_a))
    return loss, {"loss": loss, "q_mean": jnp.mean(q_a)}


def make_q_policy(net: Network, params: Any, heuristics: Callable | None = None,
                  epsilon: float = EVAL_EPSILON, mask: Callable | None = None) -> Callable:
    """``policy(key, obs, state)`` for :func:`jaxdc.core.rollout.run_episodes`: epsilon-greedy on EQN's Q
    (among the actions ``mask(state)`` allows, if given; not in the thesis)."""
    heuristics = heuristics_fn(net, heuristics)

    def policy(key, obs, state):
        batched = jax.tree_util.tree_map(lambda x: x[None], state)
        allowed = None if mask is None else mask(state)[None]
        return epsilon_greedy(key, net.apply(params, obs[None], heuristics(batched))[0], epsilon, allowed)

    return policy


def make_train(config: QConfig, env: Environment, env_params: Any, net: Network,
               heuristics: Callable | None = None) -> Trainer:
    """Build the n-step Q trainer of ``net`` (an :class:`jaxdc.nets.EQN`); same interface as A2C's."""
    if not isinstance(config, QConfig):
        raise TypeError(f"config must be a QConfig, got {type(config).__name__}")
    heuristics = heuristics_fn(check_network(net), heuristics)
    tx = make_optimizer_from(config)
    b = config.num_envs

    def init(key) -> QTrainState:
        params, obs, env_state, k_train = first_batch(key, env, env_params, net, heuristics, b)
        return QTrainState(params, params, tx.init(params), env_state, obs, k_train, jnp.int32(0))

    def max_target_q(target_params, obs, env_state):
        return jnp.max(net.apply(target_params, obs, heuristics(env_state)), axis=-1)

    def env_step(ts: QTrainState, carry, _):
        env_state, obs, key = carry
        key, k_act, k_step, k_reset = jax.random.split(key, 4)
        h = heuristics(env_state)
        action = epsilon_greedy(k_act, net.apply(ts.params, obs, h), config.epsilon(ts.update))
        # Environment.step's auto-reset, written out: a truncated step bootstraps from the
        # target Q of its last *state* (heuristics need the state, not just the observation).
        obs_end, state_end, reward, term, trunc, info = jax.vmap(env.step_env, in_axes=(0, 0, 0, None))(
            jax.random.split(k_step, b), env_state, action, env_params)
        final_value = jax.lax.cond(
            trunc.any(),
            lambda: jnp.where(trunc, max_target_q(ts.target_params, obs_end, state_end), 0.0),
            lambda: jnp.zeros_like(reward))
        done = term | trunc
        obs_new, state_new = jax.vmap(env.reset_env, in_axes=(0, None))(jax.random.split(k_reset, b), env_params)
        t = Transition(obs, h, action, reward, term, trunc, final_value,
                        jnp.where(done, info["episode_reward"], 0.0), jnp.zeros_like(action))
        return (tree_select(done, state_new, state_end), tree_select(done, obs_new, obs_end), key), t

    def update(ts: QTrainState):
        (env_state, obs, key), traj = jax.lax.scan(
            lambda c, x: env_step(ts, c, x), (ts.env_state, ts.obs, ts.key), None, config.t_max,
            unroll=config.unroll)
        returns = nstep_returns(traj.reward, traj.terminated, traj.truncated, traj.final_value,
                                max_target_q(ts.target_params, obs, env_state), config.gamma)
        flat = lambda x: x.reshape((-1,) + x.shape[2:])  # noqa: E731
        grads, metrics = jax.grad(q_loss, has_aux=True)(
            ts.params, net.apply, flat(traj.obs), flat(traj.heuristics), flat(traj.action), flat(returns))
        updates, opt_state = tx.update(grads, ts.opt_state, ts.params)
        params = optax.apply_updates(ts.params, updates)
        n = ts.update + 1
        sync = n % config.target_period == 0
        target = jax.tree_util.tree_map(lambda p, t: jnp.where(sync, p, t), params, ts.target_params)
        done = traj.terminated | traj.truncated
        metrics = dict(metrics, episodes=jnp.sum(done), episode_reward_sum=jnp.sum(traj.episode_reward),
                       reward_per_step=jnp.mean(traj.reward), epsilon=config.epsilon(ts.update))
        return QTrainState(params, target, opt_state, env_state, obs, key, n), metrics

    return Trainer.of(init, update, config)
