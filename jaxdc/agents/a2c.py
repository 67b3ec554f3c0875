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
from collections.abc import Sequence
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
from jaxdc.agents.groups import EnvGroup, check_extra_envs
from jaxdc.agents.losses import a2c_loss, aux_cross_entropy
from jaxdc.core.env import Environment, step_batch
from jaxdc.core.tree_check import check_like
from jaxdc.core.validate import check_float, check_positive_int

__all__ = ["A2CConfig", "Batch", "EnvGroup", "TrainState", "Trainer", "Transition", "a2c_loss",
           "aux_cross_entropy", "check_extra_envs", "huber", "lr_schedule", "make_optimizer", "make_policy",
           "make_train", "nstep_returns", "team_size"]


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
    obs: Any  # [num_envs, N, N, C]: C = 2 for the DCP, 2 + k for the DCG with its history planes;
    # a team's [num_envs, agents, N, N, C]; with extra_envs a tuple, one array per environment (so env_state)
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
               mask: Callable | None = None, extra_envs: Sequence[EnvGroup] = ()) -> Trainer:
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

    ``extra_envs`` (beyond the thesis; one agent, no critic): more environments whose observations have other
    shapes, e.g. the DCP on other grid sizes for a network whose body pools over the cells
    (:class:`~jaxdc.agents.groups.EnvGroup` each). The ``num_envs`` environments are then split evenly over the
    ``G = 1 + len(extra_envs)`` environments (``num_envs`` must be a multiple of ``G``, and ``num_envs * t_max``
    of ``G * minibatches``); each update rolls every group out in turn (shapes are static, so one rollout per group),
    and each Adam step's loss is the mean of the groups' losses (so of all rows: the groups are of one size) over
    minibatches that take the same share of every group; ``reset_slots`` bounds each group's resets per step. The
    training state's ``env_state`` and ``obs`` are then ``G``-tuples. Empty (default): the one environment, and
    exactly the trainer without the option.
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
    groups = (EnvGroup(env, env_params, heuristics),
              *check_extra_envs(extra_envs, config, config.minibatches, env, env_params, net, heuristics, agents,
                                critic, mask))
    g_count = len(groups)
    group_envs = config.num_envs // g_count  # environments per group
    # one group: the state holds its arrays as they are; several: a tuple of them, one per group
    pack = (lambda xs: xs[0]) if g_count == 1 else tuple
    unpack = (lambda x: (x,)) if g_count == 1 else (lambda x: x)
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
        keys = [key] if g_count == 1 else list(jax.random.split(key, g_count))
        params, obs0, state0, k_train = first_batch(keys[0], env, env_params, net, heuristics, group_envs, agents)
        resets = [jax.vmap(grp.env.reset, in_axes=(0, None))(jax.random.split(k, group_envs), grp.env_params)
                  for grp, k in zip(groups[1:], keys[1:])]
        params = params if start is None else start
        params = params if central is None else central.init(key, state0, params)
        return TrainState(params, tx.init(params), pack([state0, *(e for _, e in resets)]),
                          pack([obs0, *(o for o, _ in resets)]), k_train, jnp.int32(0))

    def env_step(group: EnvGroup, params, carry, _):
        env_state, obs, key = carry
        key, k_act, k_env = jax.random.split(key, 3)
        assert group.heuristics is not None, "each group's heuristics are resolved by make_train"
        h = group.heuristics(env_state)
        allowed = None if mask is None else jax.vmap(mask)(env_state)
        logits = masked_logits(net.apply(params, rows(obs), h)[0], allowed)
        action = jax.random.categorical(k_act, logits).astype(jnp.int32)
        obs2, env_state2, reward, term, trunc, info = step_batch(
            group.env, k_env, env_state, by_env(action), group.env_params, config.reset_slots)
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

    def normalized(batches: tuple[Batch, ...]) -> tuple[jax.Array | None, ...]:
        """The batches' advantages, standardized together when ``normalize_advantages`` (the active agents'
        steps only, for a team)."""
        if not config.normalize_advantages:
            return tuple(b.advantages for b in batches)
        advs = [b.advantages for b in batches if b.advantages is not None]
        assert len(advs) == len(batches), "normalize_advantages needs the batch's advantages"
        weight = batches[0].weight
        if weight is None:
            every = jnp.concatenate(advs)
            mean, sd = jnp.mean(every), jnp.std(every)
            return tuple((a - mean) / (sd + 1e-8) for a in advs)
        adv = advs[0]  # a team: one group
        w = weight / jnp.maximum(jnp.sum(weight), 1.0)
        centred = adv - jnp.sum(w * adv)
        return (centred / (jnp.sqrt(jnp.sum(w * centred ** 2)) + 1e-8),)

    def batch_loss(params, batch: Batch, adv):
        apply_fn = net.apply if central is None or batch.world is None else central.apply_with(net.apply, batch.world)
        return a2c_loss(params, apply_fn, batch.obs, batch.heuristics, batch.action, batch.returns, config,
                        batch.aux_target, batch.old_log_prob, adv, batch.weight, batch.allowed)

    def loss(params, batches: tuple[Batch, ...], advs: tuple[jax.Array | None, ...]):
        """The mean of the groups' losses (one group: its loss)."""
        if g_count == 1:
            return batch_loss(params, batches[0], advs[0])
        parts = [batch_loss(params, b, a) for b, a in zip(batches, advs)]
        return (sum(p[0] for p in parts) / g_count,
                jax.tree_util.tree_map(lambda *m: sum(m) / g_count, *(p[1] for p in parts)))

    def adam_step(carry, batches: tuple[Batch, ...]):
        params, opt_state = carry
        grads, metrics = jax.grad(loss, has_aux=True)(params, batches, normalized(batches))
        updates, opt_state = tx.update(grads, opt_state, params)
        return (optax.apply_updates(params, updates), opt_state), metrics

    def learn(params, opt_state, key, batches: tuple[Batch, ...]):
        """Algorithm 10's one Adam step on the batch, or ``epochs`` passes over ``minibatches`` shuffled parts."""
        if config.steps_per_update == 1:
            (params, opt_state), metrics = adam_step((params, opt_state), batches)
            return params, opt_state, key, metrics

        def epoch(carry, k_epoch):
            keys = [k_epoch] if g_count == 1 else list(jax.random.split(k_epoch, g_count))
            parts = []
            for batch, k_group in zip(batches, keys):
                perm = jax.random.permutation(k_group, config.batch_size // g_count * k)
                parts.append(jax.tree_util.tree_map(
                    lambda x, perm=perm: x[perm].reshape((config.minibatches, -1) + x.shape[1:]), batch))
            return jax.lax.scan(adam_step, carry, tuple(parts), unroll=True)

        # unrolled: on XLA's CPU backend a convolution inside a scan's loop body runs many times slower
        key, k_perm = jax.random.split(key)
        (params, opt_state), metrics = jax.lax.scan(epoch, (params, opt_state),
                                                    jax.random.split(k_perm, config.epochs), unroll=True)
        return params, opt_state, key, jax.tree_util.tree_map(jnp.mean, metrics)

    def collect(group: EnvGroup, params, env_state, obs, key):
        """One group's rollout of ``t_max`` steps and its flattened :class:`Batch`."""
        (env_state, obs, key), traj = jax.lax.scan(
            functools.partial(env_step, group, params), (env_state, obs, key), None,
            config.t_max, unroll=config.unroll)
        flat = lambda x: x.reshape((-1,) + x.shape[2:])  # noqa: E731  [T, B, ...] -> [T*B, ...]
        old_log_prob = advantages = values = None
        if needs_old_policy:  # options: pi_old and V(s_t) of the rollout, before this update
            logits, values = net.apply(params, flat(traj.obs), flat(traj.heuristics))[:2]
            values = values if central is None else central.row_values(params, flat(traj.world))
            old_logp = jax.nn.log_softmax(masked_logits(logits, None if traj.allowed is None else flat(traj.allowed)))
            old_log_prob = jnp.take_along_axis(old_logp, flat(traj.action)[:, None], -1)[:, 0]
            values = values.reshape(traj.reward.shape)
        returns = nstep_returns(traj.reward, traj.terminated, traj.truncated, traj.final_value,
                                values_of(params, obs, None if central is None else central.world(env_state)),
                                config.gamma, values, config.gae_lambda)
        if needs_old_policy:
            assert values is not None
            advantages = flat(returns - values)
        batch = Batch(flat(traj.obs), flat(traj.heuristics), flat(traj.action), flat(returns),
                      flat(traj.aux_target), old_log_prob, advantages,
                      None if traj.weight is None else flat(traj.weight),
                      None if central is None else jnp.repeat(flat(traj.world), k, axis=0),
                      None if traj.allowed is None else flat(traj.allowed))
        return env_state, obs, key, traj, batch

    def update(ts: TrainState):
        key, states, observations, trajs, batches = ts.key, [], [], [], []
        for group, env_state, obs in zip(groups, unpack(ts.env_state), unpack(ts.obs)):  # the key runs through
            env_state, obs, key, traj, batch = collect(group, ts.params, env_state, obs, key)
            states.append(env_state)
            observations.append(obs)
            trajs.append(traj)
            batches.append(batch)
        params, opt_state, key, metrics = learn(ts.params, ts.opt_state, key, tuple(batches))

        def total(f: Callable[[Transition], jax.Array]) -> jax.Array:  # over the groups
            return functools.reduce(jnp.add, [f(t) for t in trajs])
        # a team's episode is on each of its k rows: counted once
        episodes = total(lambda t: jnp.sum(t.terminated | t.truncated))
        episode_reward_sum = total(lambda t: jnp.sum(t.episode_reward))
        if agents is not None:
            episodes, episode_reward_sum = episodes // k, episode_reward_sum / k
        reward_per_step = total(lambda t: jnp.mean(t.reward)) / g_count
        metrics = dict(metrics, episodes=episodes, episode_reward_sum=episode_reward_sum,
                       reward_per_step=reward_per_step)
        return TrainState(params, opt_state, pack(states), pack(observations), key, ts.update + 1), metrics

    return Trainer.of(init, update, config)
