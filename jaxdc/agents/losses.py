"""The loss of A2C (section 4.4.3) and the auxiliary cross-entropy of Eq. 5.1 (section 5.4.4), for
:mod:`jaxdc.agents.a2c`."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable

import jax
import jax.numpy as jnp

from jaxdc.agents.common import huber, masked_logits

if TYPE_CHECKING:
    from jaxdc.agents.a2c import A2CConfig

__all__ = ["a2c_loss", "aux_cross_entropy"]


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
