"""What the synchronous trainers share (sections 4.4.3, 4.5): settings, returns, loss, optimizer, networks' contract.

A2C (:mod:`jaxdc.agents.a2c`, Algorithm 10) and n-step Q-learning
(:mod:`jaxdc.agents.nstep_q`, section 4.5.5) step ``num_envs`` environments in
lock-step for ``t_max`` steps, compute n-step returns backwards from the last
state, and take Adam steps with the learning rate annealed linearly to 0 over
``T_max`` (section 4.5). The pieces they both use live here:

* :class:`RunConfig`: the settings both algorithms read (each config adds
  only its own fields);
* :class:`Transition`: one step of a rollout; :func:`nstep_returns`;
  :func:`huber`;
* :func:`lr_schedule` and :func:`make_adam`: the annealed Adam;
* :class:`Network`: the attributes a trainer reads from a network;
  :func:`heuristics_fn`, the heuristics hook;
* :class:`Trainer`: what ``make_train`` returns (:meth:`Trainer.of` builds it); :func:`first_batch`, a run's
  start;
* :func:`team_size` and :func:`no_heuristics` for an environment of ``k`` agents; :func:`masked_logits` and
  :func:`check_mask` for an action mask.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from typing import Any, Callable, NamedTuple, Protocol, runtime_checkable

import jax
import jax.numpy as jnp
import optax

from jaxdc.core.batched import reset_batched
from jaxdc.core.env import Environment
from jaxdc.core.validate import INT32_MAX, check_float, check_positive_int


@runtime_checkable
class Network(Protocol):
    """What a trainer reads from a network (a flax module of :mod:`jaxdc.nets`) besides ``init``/``apply``.

    Attributes:
      num_actions: ``A``, the size of the policy (or Q) output.
      uses_heuristics: whether ``apply(params, obs, heuristics)`` reads the heuristic action vectors of
        section 4.4.3 (ENN, EQN); a trainer computes them only then.
      has_aux: whether ``apply`` returns a third output, the auxiliary (opponent-action) logits of
        Eq. 5.1 (EMNN, OMN + CoNN).
      aux_params: the top-level parameter names of a separate auxiliary network (OMN's ``("omn",)``), which
        may get their own learning rate; empty if there is none.
    """

    num_actions: int
    uses_heuristics: bool
    has_aux: bool
    aux_params: tuple[str, ...]

    def init(self, *args: Any, **kwargs: Any) -> Any: ...

    def apply(self, *args: Any, **kwargs: Any) -> Any: ...


def check_network(net: Any) -> Network:
    """``net`` if it declares the :class:`Network` attributes, else a ``TypeError`` naming the missing ones."""
    missing = [a for a in ("num_actions", "uses_heuristics", "has_aux", "aux_params") if not hasattr(net, a)]
    if missing:
        raise TypeError(f"{type(net).__name__} is not a jaxdc network: it lacks {missing} "
                        "(see jaxdc.agents.common.Network)")
    return net


@dataclasses.dataclass(frozen=True)
class RunConfig:
    """The settings every synchronous trainer reads; defaults are those of section 4.5.

    Attributes:
      total_steps: ``T_max``, environment steps over all environments (the
        thesis' "1 million steps"); the learning rate reaches 0 there.
      num_envs: parallel environments (the thesis' 16 threads).
      t_max: rollout length per update (the thesis' maximum batch size 32).
      gamma: discount factor (0.99).
      lr: initial Adam learning rate (1e-4), annealed linearly to 0.
      b1, b2: Adam's betas (0.9, 0.999).
      max_grad_norm: clip the global gradient norm (off by default; the thesis
        names no clipping).
      reset_slots: fresh initial states drawn per step for the environments that
        finished (:func:`jaxdc.core.env.step_batch`); ``None`` draws one per
        environment.
      unroll: ``unroll`` of the rollout ``lax.scan`` (``t_max`` unrolls it fully;
        on XLA:CPU a convolution inside a loop body can be much slower).
    """

    total_steps: int = 1_000_000
    num_envs: int = 16
    t_max: int = 32
    gamma: float = 0.99
    lr: float = 1e-4
    b1: float = 0.9
    b2: float = 0.999
    max_grad_norm: float | None = None
    reset_slots: int | None = None
    unroll: int = 1

    def __post_init__(self):
        for name in ("total_steps", "num_envs", "t_max", "unroll"):
            check_positive_int(name, getattr(self, name), numpy=False, high=INT32_MAX)
        check_float("lr (learning rate)", self.lr, low=0.0, low_open=True)
        check_float("gamma", self.gamma, low=0.0, high=1.0)
        for name in ("b1", "b2"):
            check_float(name, getattr(self, name), low=0.0, high=1.0)
        if self.max_grad_norm is not None:
            check_float("max_grad_norm", self.max_grad_norm, low=0.0, low_open=True)
        if self.reset_slots is not None:
            check_positive_int("reset_slots", self.reset_slots, numpy=False, high=INT32_MAX)
        if self.total_steps < self.batch_size:
            raise ValueError(
                f"total_steps ({self.total_steps}) must be >= num_envs * t_max ({self.batch_size}), "
                "the environment steps of one update")

    @property
    def batch_size(self) -> int:
        """Environment steps per update: ``num_envs * t_max``."""
        return self.num_envs * self.t_max

    @property
    def num_updates(self) -> int:
        """Updates in the whole run: ``total_steps // batch_size``."""
        return self.total_steps // self.batch_size


class Transition(NamedTuple):
    """One step of the batch; stacked by the rollout scan into ``[t_max, num_envs, ...]``."""

    obs: jax.Array
    heuristics: jax.Array
    action: jax.Array
    reward: jax.Array
    terminated: jax.Array
    truncated: jax.Array
    final_value: jax.Array  # V(last obs of the finished episode) where truncated, else 0
    episode_reward: jax.Array  # the finished episode's reward where done, else 0
    aux_target: jax.Array  # int32 label of the auxiliary head (e.g. the opponent's action o_t), else 0
    weight: jax.Array | None = None  # teams (a2c): 1 where the agent was active, else 0; None: one agent
    world: jax.Array | None = None  # a centralised critic's (a2c): the environments' world states [B, ...]; else None
    allowed: jax.Array | None = None  # with an action mask (a2c): bool [B, A], the allowed actions; else None


class Trainer(NamedTuple):
    """What ``make_train`` of :mod:`jaxdc.agents.a2c` and :mod:`jaxdc.agents.nstep_q` returns."""

    init: Callable  # key -> training state; jitted
    update: Callable  # state -> (state, metrics); jitted
    run: Callable  # (state, n) -> (state, metrics [n]); jitted, n static
    train: Callable  # key -> (state, metrics [num_updates])
    config: RunConfig

    @classmethod
    def of(cls, init: Callable, update: Callable, config: RunConfig) -> Trainer:
        """The trainer of ``init`` and one ``update``: ``run(state, n)`` scans ``n`` updates, ``train(key)`` runs
        ``config.num_updates`` of them from ``init(key)``; all four jitted (``init`` is the first batch of
        environments and the network's initialisation: op by op it costs seconds of dispatch per trainer)."""

        def run(ts, n: int):
            return jax.lax.scan(lambda s, _: update(s), ts, None, n)

        def train(key):
            return run(init(key), config.num_updates)

        return cls(jax.jit(init), jax.jit(update), jax.jit(run, static_argnums=1), jax.jit(train), config)


def nstep_returns(rewards: jax.Array, terminated: jax.Array, truncated: jax.Array, final_values: jax.Array,
                  last_value: jax.Array, gamma: Any, values: jax.Array | None = None, lam: float = 1.0) -> jax.Array:
    """The n-step returns of Algorithm 10 over a rollout of ``[T, B]`` steps (lambda-returns if ``lam < 1``).

    Backwards from ``R_T = V(s_T)`` (``last_value``), ``R_t = r_t + gamma * X``
    where ``X`` is 0 if step ``t`` reached a terminal state (Algorithm 10's
    "0 if s_t is terminal"), ``V`` of the episode's last observation if it was
    truncated by the step cap (``final_values``; the state is not terminal, so
    its value bootstraps), and ``R_{t+1}`` otherwise. Hence
    ``R_t = sum_{i<k} gamma^i r_{t+i} + gamma^k V(s_{t+k})`` (section 4.4.3).

    With ``lam < 1`` (an option, not in the thesis) the continuing case is
    ``X = (1 - lam) V(s_{t+1}) + lam R_{t+1}`` with ``values`` ``[T, B]`` =
    ``V(s_t)``: the TD(lambda) return, whose difference from ``V(s_t)`` is
    GAE's advantage (Schulman et al. 2016). ``lam = 1`` is the n-step return.
    """
    if lam == 1.0:
        next_values = jnp.zeros_like(rewards)  # unused
    else:
        if values is None:
            raise ValueError(f"lam={lam!r} < 1 needs values=V(s_t) [T, B]")
        next_values = jnp.concatenate([values[1:], last_value[None]], axis=0)

    def back(next_return, step):
        r, term, trunc, v_final, v_next = step
        cont = next_return if lam == 1.0 else (1.0 - lam) * v_next + lam * next_return
        bootstrap = jnp.where(term, 0.0, jnp.where(trunc, v_final, cont))
        ret = r + gamma * bootstrap
        return ret, ret

    _, returns = jax.lax.scan(back, last_value, (rewards, terminated, truncated, final_values, next_values),
                              reverse=True)
    return returns


def huber(x: jax.Array, delta: float = 1.0) -> jax.Array:
    """Huber loss of section 4.4.3: ``0.5 x^2`` if ``|x| <= delta``, else ``delta (|x| - 0.5 delta)``.

    Written out instead of ``optax.huber_loss`` on purpose: both give the same
    values (for ``|x| < 2**24``), but optax writes it as
    ``0.5 min(|x|, delta)**2 + delta (|x| - min(|x|, delta))``, whose backward
    pass differs in the last bit. Training with it would end on other
    parameters than the runs that made the shipped networks, so this form keeps
    training bit-identical to them.
    """
    ax = jnp.abs(x)
    return jnp.where(ax <= delta, 0.5 * x * x, delta * (ax - 0.5 * delta))


def lr_schedule(config: RunConfig, lr: float | None = None) -> optax.Schedule:
    """Learning rate per update: ``lr`` (default ``config.lr``) linearly to 0 at update ``num_updates``
    (at ``T_max``)."""
    return optax.linear_schedule(config.lr if lr is None else lr, 0.0, config.num_updates)


def make_adam(config: RunConfig, lr: float | None = None, steps_per_update: int = 1) -> optax.GradientTransformation:
    """Adam(b1, b2) on :func:`lr_schedule` of ``lr``, stepped per update whatever ``steps_per_update``."""
    per_update, k = lr_schedule(config, lr), steps_per_update
    return optax.adam(per_update if k == 1 else (lambda count: per_update(count // k)), b1=config.b1, b2=config.b2)


def aux_param_labels(params: Any, names: Sequence[str]) -> Any:
    """``"aux"`` for every leaf under a top-level parameter name in ``names`` (e.g. ``("omn",)``), else ``"main"``."""
    names = tuple(names)
    inner = params["params"] if isinstance(params, dict) and "params" in params else params
    missing = [n for n in names if n not in inner]
    if missing:
        raise ValueError(f"aux_params {names}: no parameters named {missing}; the network has {sorted(inner)}")
    labels = {k: jax.tree_util.tree_map(lambda _, k=k: "aux" if k in names else "main", v) for k, v in inner.items()}
    return {**params, "params": labels} if inner is not params else labels


def make_optimizer_from(config: RunConfig, steps_per_update: int = 1, aux_lr: float | None = None,
                        aux_params: Sequence[str] = ()) -> optax.GradientTransformation:
    """:func:`make_adam` with optional global-norm clipping (``config.max_grad_norm``).

    With ``aux_lr`` (an option, not in the thesis) the parameters under the top-level names
    ``aux_params`` get their own Adam with initial learning rate ``aux_lr`` (``optax.multi_transform``);
    Adam is element-wise, so with ``aux_lr == lr`` this is the single Adam exactly.
    """
    adam = make_adam(config, steps_per_update=steps_per_update)
    if aux_lr is not None:
        if not aux_params:
            raise ValueError("aux_lr needs a network with aux_params (the top-level parameter names of its "
                             "auxiliary network, e.g. OMNCoNN's ('omn',))")
        adam = optax.multi_transform({"main": adam, "aux": make_adam(config, aux_lr, steps_per_update)},
                                     functools.partial(aux_param_labels, names=aux_params))
    if config.max_grad_norm is None:
        return adam
    return optax.chain(optax.clip_by_global_norm(config.max_grad_norm), adam)


def heuristics_fn(net: Network, heuristics: Callable | None) -> Callable:
    """``env_states [B] -> [B, H, A]``: the given heuristics for a network that uses them (ENN, EQN),
    zeros ``[B, 1, A]`` for one that ignores them (linear, CNN).

    The heuristics come from the caller (for the DCP,
    :func:`jaxdc.dcp.navigators.batched_heuristics`): an algorithm knows no heuristics.
    """
    if check_network(net).uses_heuristics:
        if heuristics is None:
            raise ValueError(f"{type(net).__name__} uses heuristics: pass heuristics=states -> [B, H, A] "
                             "(for the DCP: jaxdc.dcp.navigators.batched_heuristics(params, table))")
        return heuristics

    def zeros(env_states):
        b = jax.tree_util.tree_leaves(env_states)[0].shape[0]
        return jnp.zeros((b, 1, net.num_actions), jnp.float32)

    return zeros


def first_batch(key: jax.Array, env: Any, env_params: Any, net: Network, heuristics: Callable,
                num_envs: int, agents: int | None = None) -> tuple[Any, jax.Array, Any, jax.Array]:
    """A run's start: ``num_envs`` environments reset and the network's parameters initialised on their first
    observations, ``(params, obs, env_state, key)`` with ``key`` the run's own key (``key`` split three ways).
    With ``agents`` (a team environment) the observations are ``[num_envs, agents, ...]`` and the network is
    initialised on their ``num_envs * agents`` rows."""
    k_net, k_env, k_train = jax.random.split(key, 3)
    obs, env_state = reset_batched(env, k_env, num_envs, env_params)
    rows = obs if agents is None else obs.reshape((-1,) + obs.shape[2:])
    params = net.init(k_net, rows, heuristics(env_state))
    return params, obs, env_state, k_train


def masked_logits(logits: jax.Array, allowed: jax.Array | None) -> jax.Array:
    """``logits [..., A]`` with the actions outside ``allowed`` (bool ``[..., A]``; ``None``: all) pushed to the
    lowest float, so that a softmax gives them probability 0 and an argmax never takes them (an action mask,
    e.g. :mod:`jaxdc.dcp.masks`; the caller guarantees at least one allowed action)."""
    if allowed is None:
        return logits
    return jnp.where(allowed, logits, jnp.finfo(logits.dtype).min)


# -- teams and masks ------------------------------------------------------------------------
def team_size(env: Environment) -> int | None:
    """``k`` for an environment that takes one action per agent (``env.action_shape == (k,)``, e.g.
    :class:`jaxdc.dcg.team.DCGTeam`), ``None`` for a one-agent environment (no ``action_shape``)."""
    shape = getattr(env, "action_shape", None)
    if shape is None:
        return None
    if len(shape) != 1:
        raise ValueError(f"{type(env).__name__}.action_shape is {shape}: the trainer takes one agent axis (k,)")
    return int(shape[0])


def no_heuristics(num_actions: int, agents: int) -> Callable:
    """Zero heuristics ``[B * k, 1, A]`` for the rows of a team batch (its networks read none)."""

    def zeros(env_states):
        b = jax.tree_util.tree_leaves(env_states)[0].shape[0]
        return jnp.zeros((b * agents, 1, num_actions), jnp.float32)

    return zeros


def check_mask(mask: Any, env: Environment, env_params: Any, net: Network, agents: int | None) -> None:
    """Refuse, outside jit, a ``mask`` that is not ``state -> bool [num_actions]`` for one state of ``env`` (traced
    abstractly on a reset state), or any mask on a team."""
    if agents is not None:
        raise ValueError(f"mask: an action mask plays one agent's state, not a team of {agents} "
                         f"({type(env).__name__})")
    if not callable(mask):
        raise TypeError(f"mask must be a function state -> bool [{net.num_actions}] (e.g. "
                        f"jaxdc.core.masks.make_mask), got {mask!r}")
    state = jax.eval_shape(lambda k: env.reset(k, env_params)[1], jax.random.PRNGKey(0))
    out = jax.eval_shape(mask, state)
    if getattr(out, "shape", None) != (net.num_actions,) or getattr(out, "dtype", None) != jnp.bool_:
        raise ValueError(f"mask must return bool [{net.num_actions}] for one state (one flag per action), got "
                         f"{getattr(out, 'dtype', type(out).__name__)} {getattr(out, 'shape', '')}")
