"""Synchronous advantage actor-critic: Algorithm 10 (section 4.4.3) without threads.

The thesis trains ENN with 16 asynchronous A3C threads. Here ``num_envs``
environments step in lock-step instead (A2C), which keeps the algorithm and
removes the threads:

1. every environment acts ``t_max`` steps with the current policy
   ``pi(a|s; theta')`` (auto-reset: an episode that ends is replaced at once);
2. the n-step returns of Algorithm 10 are computed backwards from the last
   state, ``R_i = r_i + gamma R_{i+1}``, bootstrapped with ``V(s_{t+k})``
   unless the state is terminal (:func:`nstep_returns`);
3. one Adam step on the loss of section 4.4.3: the policy loss
   ``-log pi(a_t|s_t) A_t`` with ``A_t = R_t - V(s_t)`` held constant, the
   Huber value loss on ``R_t - V(s_t)``, and optionally an entropy bonus.

The learning rate is annealed linearly from ``lr`` to 0 over ``total_steps``
environment steps (section 4.5, "linearly annealed to 0 over the course of
training"); Adam's betas are 0.9 and 0.999.

Options beside that faithful default (all off by default, see
``docs/learning.md`` for measured settings): ``gae_lambda < 1`` replaces the
n-step returns by lambda-returns (GAE, Schulman et al. 2016), ``clip_eps``
turns the policy term into PPO's clipped surrogate (Schulman et al. 2017),
``epochs`` and ``minibatches`` reuse each rollout for several shuffled
gradient steps, and ``normalize_advantages`` standardizes the advantages of
each minibatch.

**Teams** (beyond the thesis: its conclusion to chapter 5 proposes several cooperating collectors). On an
environment whose actions are one per agent (``env.action_shape == (k,)``, e.g.
:class:`jaxdc.dcg.team.DCGTeam`) the trainer is independent actor-critic with parameter sharing (IPPO with
the PPO-style options, as JaxMARL's): the ``k`` agents of every environment are ``k`` rows of the batch, each
acting on its own observation with the one network; every agent learns from the team reward (the shared
reward of a cooperative game); an agent's steps count only while it is active (``state.active``; a disabled
collector's ignored actions carry no gradient). One environment step is still one step of ``total_steps``.
``make_train(..., critic=net)`` turns it into MAPPO (Yu et al. 2022; issue 29): the values come from a centralised
critic on the environment's world state (:mod:`jaxdc.agents.centralised`), the actors still act on their own.

Everything per step is a pure function of arrays. :func:`make_train` returns
the pieces: ``init(key) -> TrainState``, a jitted ``update(state)`` (one
rollout plus one gradient step), a jitted ``run(state, n)`` (``n`` updates in
one ``lax.scan``) and ``train(key)`` (a whole run, PureJaxRL style). The
training state holds everything a run depends on (parameters, optimizer
state, environment states, RNG key, update counter), so a run split into
pieces (and checkpointed in between) ends exactly where an uninterrupted one
does.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from jaxdc.agents.centralised import CentralCritic
from jaxdc.agents.common import (
    Network,
    RunConfig,
    Trainer,
    Transition,
    check_mask,
    check_network,
    first_batch,
    heuristics_fn,
    huber,
    lr_schedule,
    make_optimizer_from,
    masked_logits,
    no_heuristics,
    nstep_returns,
    team_size,
)
from jaxdc.core.env import Environment, step_batch
from jaxdc.core.tree_check import check_like
from jaxdc.core.validate import check_float, check_positive_int

__all__ = ["A2CConfig", "Batch", "TrainState", "Trainer", "Transition", "a2c_loss", "aux_cross_entropy", "huber",
           "lr_schedule", "make_optimizer", "make_policy", "make_train", "nstep_returns", "team_size"]


@dataclasses.dataclass(frozen=True)
class A2CConfig(RunConfig):
    """A2C's hyperparameters: :class:`~jaxdc.agents.common.RunConfig`'s shared settings (``total_steps``,
    ``num_envs``, ``t_max``, ``gamma``, ``lr``, ``b1``, ``b2``, ``max_grad_norm``, ``reset_slots``, ``unroll``)
    and the loss of section 4.4.3 with the options beside it; defaults are those of section 4.5 unless noted.

    Attributes:
      value_coef: weight of the Huber value loss (1.0: the thesis adds the two
        terms of its loss).
      entropy_coef: weight of the entropy bonus. Default 0.01, the value of
        A3C [25] from which Algorithm 10 is adopted; the thesis says its loss
        "mainly consists of two terms", and names no third. Set 0 for the two
        terms alone.
      aux_coef: weight of the auxiliary cross-entropy of a network with an
        auxiliary head (``has_aux``: its ``apply`` returns ``(logits, value,
        aux_logits)``): section 5.4.4's ``alpha`` of Eq. 5.1 for EMNN; 1.0 for
        OMN + CoNN, whose OMN is trained by that cross-entropy alone (Algorithm
        12). Ignored by a network without such a head.
      gae_lambda: lambda of the lambda-returns (:func:`nstep_returns`); 1.0 is
        Algorithm 10's n-step return. Not in the thesis.
      clip_eps: PPO's clipping of the probability ratio (e.g. 0.2); ``None``
        is Algorithm 10's policy gradient. Not in the thesis.
      epochs, minibatches: passes over each rollout, and shuffled minibatches
        per pass (one Adam step each); 1 and 1 are Algorithm 10's one step.
        The learning rate still falls linearly per update. Not in the thesis.
      normalize_advantages: standardize the advantages of each minibatch
        (mean 0, SD 1). Not in the thesis.
      aux_lr: initial learning rate of the auxiliary network's own parameters
        (those under the top-level names in the network's ``aux_params``, e.g.
        OMN's in OMN + CoNN), annealed to 0 like ``lr`` by a second Adam;
        ``None`` (default) trains every parameter with ``lr``, as Algorithm 12's
        one update does. Not in the thesis.
    """

    value_coef: float = 1.0
    entropy_coef: float = 0.01
    aux_coef: float = 1.0
    gae_lambda: float = 1.0
    clip_eps: float | None = None
    epochs: int = 1
    minibatches: int = 1
    normalize_advantages: bool = False
    aux_lr: float | None = None

    def __post_init__(self):
        super().__post_init__()
        for name in ("epochs", "minibatches"):
            check_positive_int(name, getattr(self, name), numpy=False)
        if self.aux_lr is not None:
            check_float("aux_lr (learning rate of the auxiliary network)", self.aux_lr, low=0.0, low_open=True)
        for name in ("value_coef", "entropy_coef", "aux_coef"):
            check_float(name, getattr(self, name), low=0.0)
        check_float("gae_lambda", self.gae_lambda, low=0.0, high=1.0)
        if self.clip_eps is not None:
            check_float("clip_eps", self.clip_eps, low=0.0, high=1.0, low_open=True)
            if self.clip_eps == 1.0:
                raise ValueError(f"clip_eps must be in (0, 1) or None, got {self.clip_eps!r}")
        if self.batch_size % self.minibatches:
            raise ValueError(f"minibatches ({self.minibatches}) must divide num_envs * t_max ({self.batch_size})")

    @property
    def steps_per_update(self) -> int:
        """Adam steps per update: ``epochs * minibatches`` (1 for Algorithm 10)."""
        return self.epochs * self.minibatches


@struct.dataclass
class TrainState:
    """Everything a run depends on; checkpointing this makes a resumed run exact."""

    params: Any
    opt_state: Any
    env_state: Any  # batched [num_envs] environment states
    obs: jax.Array  # [num_envs, N, N, C]: C = 2 for the DCP, 2 + k for the DCG with its history planes;
    # a team's [num_envs, agents, N, N, C]
    key: jax.Array
    update: jax.Array  # int32, updates done so far


class Batch(NamedTuple):
    """The flattened ``[t_max * num_envs]`` rollout a gradient step sees; the last two only with the options."""

    obs: jax.Array
    heuristics: jax.Array
    action: jax.Array
    returns: jax.Array
    aux_target: jax.Array
    old_log_prob: jax.Array | None  # log pi_old(a|s), for clip_eps
    advantages: jax.Array | None  # R - V_old(s), fixed before the update
    weight: jax.Array | None = None  # teams: 1 where the agent was active at the step, else 0; None: all count
    world: jax.Array | None = None  # with a centralised critic: each row's world state; else None
    allowed: jax.Array | None = None  # with an action mask: bool [A] per row, the allowed actions; else None


# -- the pieces of the loss ---------------------------------------------------------------
def make_optimizer(config: A2CConfig, aux_params: tuple[str, ...] | None = None) -> optax.GradientTransformation:
    """A2C's optimizer: Adam(b1, b2) on :func:`lr_schedule`, stepped per update whatever ``steps_per_update``,
    optional norm clipping, and with ``config.aux_lr`` a second Adam for the parameters under ``aux_params``
    (:func:`jaxdc.agents.common.make_optimizer_from`)."""
    return make_optimizer_from(config, config.steps_per_update, config.aux_lr, aux_params or ())


def aux_cross_entropy(aux_logits: jax.Array, targets: jax.Array,
                      weights: jax.Array | None = None) -> tuple[jax.Array, jax.Array]:
    """Eq. 5.1: mean cross-entropy ``-log p(o_t)`` of the auxiliary head, and its accuracy (argmax = target);
    with ``weights`` (teams: the active agents' steps) their weighted means.

    Written out instead of ``optax.softmax_cross_entropy_with_integer_labels`` on purpose:
    optax's ``logsumexp - logit`` gives the same mean here but gradients that differ in the
    last bit, which would change every trained network; this ``log_softmax`` form keeps
    training bit-identical to the runs that made the shipped networks.
    """
    logp = jax.nn.log_softmax(aux_logits)
    logp_o = jnp.take_along_axis(logp, targets[:, None], axis=-1)[:, 0]
    hit = jnp.argmax(aux_logits, axis=-1) == targets
    if weights is None:
        return -jnp.mean(logp_o), jnp.mean(hit)
    total = jnp.maximum(jnp.sum(weights), 1.0)
    return -jnp.sum(logp_o * weights) / total, jnp.sum(hit * weights) / total


def a2c_loss(params: Any, apply_fn: Callable, obs: jax.Array, heuristics: jax.Array, actions: jax.Array,
             returns: jax.Array, config: A2CConfig, aux_targets: jax.Array | None = None,
             old_log_probs: jax.Array | None = None, advantages: jax.Array | None = None,
             weights: jax.Array | None = None,
             allowed: jax.Array | None = None) -> tuple[jax.Array, dict[str, jax.Array]]:
    """Mean over the batch of ``-log pi(a|s) A + value_coef * Huber(R - V) - entropy_coef * H(pi)``.

    ``A = R - V(s)`` is held constant (``stop_gradient``) in the policy term.
    The thesis accumulates gradients over the batch (a sum); Adam is invariant
    to that constant factor, so the mean is used. A network with an auxiliary
    head (``apply`` returns a third output) adds ``aux_coef`` times
    :func:`aux_cross_entropy` on ``aux_targets`` (section 5.4.4, Algorithm 12).

    Options (not in the thesis): ``advantages`` replaces ``A`` (e.g. normalized
    ones, computed before the update); with ``config.clip_eps`` the policy
    term is PPO's ``-min(rho A, clip(rho, 1 - eps, 1 + eps) A)``,
    ``rho = pi(a|s) / pi_old(a|s)`` from ``old_log_probs``. ``weights`` (teams: 1 for an active agent's step,
    0 for a disabled one's) turn every mean into the weighted mean. ``allowed`` (bool ``[B, A]``, an action mask)
    makes ``pi`` the masked policy the rollout sampled from (:func:`~jaxdc.agents.common.masked_logits`): its
    log-probabilities and entropy are those over the allowed actions.
    """
    mean = jnp.mean if weights is None else (lambda x: jnp.sum(x * weights) / jnp.maximum(jnp.sum(weights), 1.0))
    logits, values, *aux = apply_fn(params, obs, heuristics)
    logp = jax.nn.log_softmax(masked_logits(logits, allowed))
    logp_a = jnp.take_along_axis(logp, actions[:, None], axis=-1)[:, 0]
    advantage = returns - values
    adv = jax.lax.stop_gradient(advantage) if advantages is None else advantages
    if config.clip_eps is None:
        policy_loss = -mean(logp_a * adv)
    else:
        assert old_log_probs is not None, "clip_eps needs old_log_probs"
        ratio = jnp.exp(logp_a - old_log_probs)
        clipped = jnp.clip(ratio, 1.0 - config.clip_eps, 1.0 + config.clip_eps)
        policy_loss = -mean(jnp.minimum(ratio * adv, clipped * adv))
    value_loss = mean(huber(advantage))
    entropy = -mean(jnp.sum(jnp.exp(logp) * logp, axis=-1))
    loss = policy_loss + config.value_coef * value_loss - config.entropy_coef * entropy
    metrics = {"policy_loss": policy_loss, "value_loss": value_loss, "entropy": entropy}
    if aux:
        assert aux_targets is not None, "a network with an auxiliary head needs aux_targets"
        aux_loss, aux_accuracy = aux_cross_entropy(aux[0], aux_targets, weights)
        loss = loss + config.aux_coef * aux_loss
        metrics.update(aux_loss=aux_loss, aux_accuracy=aux_accuracy)
    return loss, dict(metrics, loss=loss)


# -- policies -----------------------------------------------------------------------------
def make_policy(net: Network, params: Any, heuristics: Callable | None = None, greedy: bool = False,
                mask: Callable | None = None) -> Callable:
    """``policy(key, obs, state) -> action`` for one environment, as :func:`jaxdc.core.rollout.run_episodes` wants.

    Samples from ``pi`` (section 4.5: "the output of ENN is used as a
    stochastic policy"), or takes its argmax if ``greedy``. ``mask`` (``state -> bool [A]``, e.g.
    :func:`jaxdc.dcp.masks.reach_base`; not in the thesis) restricts both to the allowed actions.
    """
    heuristics = heuristics_fn(net, heuristics)

    def policy(key, obs, state):
        batched = jax.tree_util.tree_map(lambda x: x[None], state)
        logits = net.apply(params, obs[None], heuristics(batched))[0]
        if mask is not None:
            logits = masked_logits(logits, mask(state)[None])
        if greedy:
            return jnp.argmax(logits[0]).astype(jnp.int32)
        return jax.random.categorical(key, logits[0]).astype(jnp.int32)

    return policy


# -- training -----------------------------------------------------------------------------
def make_train(config: A2CConfig, env: Environment, env_params: Any, net: Network, heuristics: Callable | None = None,
               aux_target: Callable | None = None, init_params: Any = None, critic: Any = None,
               mask: Callable | None = None) -> Trainer:
    """Build the A2C trainer of ``net`` on ``env`` with ``env_params`` (validated outside jit).

    ``heuristics`` (``env_states [B] -> [B, H, A]``) feeds a network that uses them (ENN).
    ``aux_target`` (``info -> int labels [B]`` of the step that follows the observation, e.g.
    ``lambda info: info["opponent_action"]`` for the DCG) supervises a network's auxiliary head;
    a network with such a head (``net.has_aux``) needs it.

    On a team environment (:func:`team_size` ``k``; the module docs) the observations are ``[B, k, ...]`` and
    ``aux_target`` gives ``[B, k]`` labels; a network that reads heuristics is refused (a team game has none).

    ``init_params`` (beyond the thesis: a warm start, e.g. :func:`jaxdc.nets.transfer.widen_inputs` of a trained
    network) replaces the network's fresh initialisation; it must have the structure and shapes of ``net``'s
    parameters (``ValueError``). Everything else -- the optimiser's state, the environments, the keys -- starts
    as without it.

    ``critic`` (beyond the thesis: MAPPO, Yu et al. 2022; issue 29), on a team environment with a
    ``world_state(state, params)`` hook only: a flax module ``world [B, ...] -> value [B]`` (e.g.
    :class:`jaxdc.nets.critic.WorldCritic`) whose value on the world state replaces the network's own in the
    returns, the truncation bootstrap and the value loss (:mod:`jaxdc.agents.centralised`); its parameters join the
    trained tree (``init_params`` is then the actor's alone). ``None`` (default): IPPO, each row's own value.

    ``mask`` (beyond the thesis; one agent only): ``state -> bool [A]`` for one environment state (e.g.
    :func:`jaxdc.core.masks.make_mask`): the rollout samples among the allowed actions, the batch keeps them, and
    the loss is that of the masked policy (:func:`a2c_loss`'s ``allowed``). ``None`` (default): every action.
    """
    if not isinstance(config, A2CConfig):
        raise TypeError(f"config must be an A2CConfig, got {type(config).__name__}")
    agents = team_size(env)
    if agents is not None:
        if check_network(net).uses_heuristics:
            raise ValueError(f"{type(net).__name__} reads heuristics, which {type(env).__name__} (a team of "
                             f"{agents} agents) does not give; train a network without them")
        if heuristics is not None:
            raise ValueError(f"heuristics: a team environment ({type(env).__name__}) takes none, got {heuristics!r}")
        heuristics = no_heuristics(net.num_actions, agents)
    heuristics = heuristics_fn(check_network(net), heuristics)
    k = agents or 1
    # a team's [B, k, ...] arrays as k rows per environment, and an environment's [B] values per row
    rows = (lambda x: x) if agents is None else (lambda x: x.reshape((-1,) + x.shape[2:]))
    per_agent = (lambda x: x) if agents is None else (lambda x: jnp.repeat(x, k, axis=0))
    by_env = (lambda x: x) if agents is None else (lambda x: x.reshape((-1, k)))
    if mask is not None:
        check_mask(mask, env, env_params, net, agents)
    if net.has_aux and aux_target is None:
        raise ValueError(f"{type(net).__name__} has an auxiliary head: pass aux_target=info -> labels [B] "
                         "(for the DCG: lambda info: info['opponent_action'])")
    if config.aux_lr is not None and not net.aux_params:
        raise ValueError(f"aux_lr={config.aux_lr!r}: {type(net).__name__} has no separate auxiliary network "
                         "(aux_params); only OMN + CoNN has one")
    central = None if critic is None else CentralCritic.of(critic, env, env_params, agents)
    tx = make_optimizer(config, net.aux_params)
    value_fn = functools.partial(net.apply, method="value")

    def values_of(params, obs, world):  # [B * k]: each row's own value, or its team state's centralised value
        return value_fn(params, rows(obs)) if central is None else central.row_values(params, world)
    needs_old_policy = config.gae_lambda < 1 or config.clip_eps is not None or config.normalize_advantages

    start = None if init_params is None else check_like(
        jax.tree_util.tree_map(lambda s: np.zeros(s.shape, s.dtype), jax.eval_shape(
            lambda k: first_batch(k, env, env_params, net, heuristics, 1, agents)[0], jax.random.PRNGKey(0))),
        init_params, "init_params", f"a {type(net).__name__} on this environment")

    def init(key) -> TrainState:
        params, obs, env_state, k_train = first_batch(key, env, env_params, net, heuristics, config.num_envs,
                                                      agents)
        params = params if start is None else start
        params = params if central is None else central.init(key, env_state, params)
        return TrainState(params, tx.init(params), env_state, obs, k_train, jnp.int32(0))

    def env_step(params, carry, _):
        env_state, obs, key = carry
        key, k_act, k_env = jax.random.split(key, 3)
        h = heuristics(env_state)
        allowed = None if mask is None else jax.vmap(mask)(env_state)
        logits = masked_logits(net.apply(params, rows(obs), h)[0], allowed)
        action = jax.random.categorical(k_act, logits).astype(jnp.int32)
        obs2, env_state2, reward, term, trunc, info = step_batch(
            env, k_env, env_state, by_env(action), env_params, config.reset_slots)
        reward, term, trunc = per_agent(reward), per_agent(term), per_agent(trunc)
        final_value = jax.lax.cond(
            trunc.any(),
            lambda: jnp.where(trunc, values_of(params, info["final_observation"], info.get("world_state")), 0.0),
            lambda: jnp.zeros_like(reward))
        done = term | trunc
        target = aux_target(info).astype(jnp.int32).reshape(action.shape) if aux_target is not None \
            else jnp.zeros_like(action)
        weight = None if agents is None else rows(env_state.active).astype(jnp.float32)
        t = Transition(rows(obs), h, action, reward, term, trunc, final_value,
                       jnp.where(done, per_agent(info["episode_reward"]), 0.0), target, weight,
                       None if central is None else central.world(env_state), allowed)
        return (env_state2, obs2, key), t

    def adam_step(carry, batch: Batch):
        params, opt_state = carry
        adv = batch.advantages
        if config.normalize_advantages:
            assert adv is not None, "normalize_advantages needs the batch's advantages"
            if batch.weight is None:
                adv = (adv - jnp.mean(adv)) / (jnp.std(adv) + 1e-8)
            else:  # the active agents' steps only
                w = batch.weight / jnp.maximum(jnp.sum(batch.weight), 1.0)
                centred = adv - jnp.sum(w * adv)
                adv = centred / (jnp.sqrt(jnp.sum(w * centred ** 2)) + 1e-8)
        apply_fn = net.apply if central is None or batch.world is None else central.apply_with(net.apply, batch.world)
        grads, metrics = jax.grad(a2c_loss, has_aux=True)(
            params, apply_fn, batch.obs, batch.heuristics, batch.action, batch.returns, config,
            batch.aux_target, batch.old_log_prob, adv, batch.weight, batch.allowed)
        updates, opt_state = tx.update(grads, opt_state, params)
        return (optax.apply_updates(params, updates), opt_state), metrics

    def learn(params, opt_state, key, batch: Batch):
        """Algorithm 10's one Adam step on the batch, or ``epochs`` passes over ``minibatches`` shuffled parts."""
        if config.steps_per_update == 1:
            (params, opt_state), metrics = adam_step((params, opt_state), batch)
            return params, opt_state, key, metrics

        def epoch(carry, k_epoch):
            perm = jax.random.permutation(k_epoch, config.batch_size * k)
            parts = jax.tree_util.tree_map(lambda x: x[perm].reshape((config.minibatches, -1) + x.shape[1:]), batch)
            return jax.lax.scan(adam_step, carry, parts, unroll=True)

        # unrolled: on XLA's CPU backend a convolution inside a scan's loop body runs many times slower
        key, k_perm = jax.random.split(key)
        (params, opt_state), metrics = jax.lax.scan(epoch, (params, opt_state),
                                                    jax.random.split(k_perm, config.epochs), unroll=True)
        return params, opt_state, key, jax.tree_util.tree_map(jnp.mean, metrics)

    def update(ts: TrainState):
        (env_state, obs, key), traj = jax.lax.scan(
            functools.partial(env_step, ts.params), (ts.env_state, ts.obs, ts.key), None,
            config.t_max, unroll=config.unroll)
        flat = lambda x: x.reshape((-1,) + x.shape[2:])  # noqa: E731  [T, B, ...] -> [T*B, ...]
        old_log_prob = advantages = values = None
        if needs_old_policy:  # options: pi_old and V(s_t) of the rollout, before this update
            logits, values = net.apply(ts.params, flat(traj.obs), flat(traj.heuristics))[:2]
            values = values if central is None else central.row_values(ts.params, flat(traj.world))
            old_logp = jax.nn.log_softmax(masked_logits(logits, None if traj.allowed is None else flat(traj.allowed)))
            old_log_prob = jnp.take_along_axis(old_logp, flat(traj.action)[:, None], -1)[:, 0]
            values = values.reshape(traj.reward.shape)
        returns = nstep_returns(traj.reward, traj.terminated, traj.truncated, traj.final_value,
                                values_of(ts.params, obs, None if central is None else central.world(env_state)),
                                config.gamma, values, config.gae_lambda)
        if needs_old_policy:
            assert values is not None
            advantages = flat(returns - values)
        batch = Batch(flat(traj.obs), flat(traj.heuristics), flat(traj.action), flat(returns),
                      flat(traj.aux_target), old_log_prob, advantages,
                      None if traj.weight is None else flat(traj.weight),
                      None if central is None else jnp.repeat(flat(traj.world), k, axis=0),
                      None if traj.allowed is None else flat(traj.allowed))
        params, opt_state, key, metrics = learn(ts.params, ts.opt_state, key, batch)
        done = traj.terminated | traj.truncated
        # a team's episode is on each of its k rows: counted once
        episodes = jnp.sum(done) if agents is None else jnp.sum(done) // k
        episode_reward_sum = jnp.sum(traj.episode_reward) if agents is None else jnp.sum(traj.episode_reward) / k
        metrics = dict(metrics, episodes=episodes, episode_reward_sum=episode_reward_sum,
                       reward_per_step=jnp.mean(traj.reward))
        return TrainState(params, opt_state, env_state, obs, key, ts.update + 1), metrics

    return Trainer.of(init, update, config)
