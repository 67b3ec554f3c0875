"""The append-at-the-end tour-building criteria of section 3.4.2 (Eqs. 3.2-3.7).

One piece of code serves both problems:

* the DRP tour builders (``jaxdc.drp.tours``) score the next node of a
  partial tour ``t`` that ends at node ``e``;
* the DCP planners (``jaxdc.dcp.planners``) score the next item from the
  agent's cell on the complete graph of safest paths (section 4.4.1, Fig. 4.2).

Both see the same inputs: ``p_next[u]``, the success probability of going from
the end of the partial tour to candidate ``u``; ``p_pair[u, v]``, from ``u``
to ``v``; the rewards ``beta``; and the mask of candidates still unassigned.
The reach probability of the tour's end, ``P_t(e)``, multiplies every
marginal reward alike, so it only matters for the absolute values, not for
the choice; it is the optional ``p_end`` argument.

With ``g(u) = p_end p_next[u] beta[u]`` the marginal reward of appending ``u``
(Eq. 3.2) and ``delta(u, v) = g(v) - p_end p_next[u] p_pair[u, v] beta[v]``
the loss of Eq. 3.4, every criterion returns a score where **higher is
better** (minimised criteria are negated), and ``-inf`` for masked-out
candidates. Ties are broken by the caller, by the lowest index
(``jnp.argmax`` returns the first maximum).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

#: Criteria in the thesis' order. GI (Eq. 3.8) inserts anywhere, so it is not an append criterion.
APPEND_CRITERIA = ("ng", "osa", "tl", "gml", "lpg")


def _pairwise(p_next, p_pair, beta, mask, p_end):
    """``after[u, v]``: marginal reward of ``v`` appended after ``u``; ``other``: valid pairs u != v."""
    after = p_end * p_next[:, None] * p_pair * beta[None, :]
    other = mask[None, :] & mask[:, None] & ~jnp.eye(mask.shape[0], dtype=bool)
    return after, other


def total_loss(p_next: Any, p_pair: Any, beta: Any, mask: Any, p_end: Any = 1.0) -> jax.Array:
    """Eq. 3.5, ``sum_{v != u} delta(u, v)``, as a matrix-vector product (no ``[K, K]`` temporary).

    ``sum_v g(v) - g(u) - p_end p_next[u] (sum_v p_pair[u, v] beta[v] - p_pair[u, u] beta[u])``
    over unassigned ``v``; batched over states this is one matrix product.
    """
    b = jnp.where(mask, beta, 0.0)
    gain = p_end * p_next * b
    via_u = p_pair @ b - jnp.diagonal(p_pair) * b
    return (jnp.sum(gain) - gain) - p_end * p_next * via_u


def append_scores(
    criterion: str,
    p_next: Any,
    p_pair: Any,
    beta: Any,
    mask: Any,
    p_end: Any = 1.0,
    lpg_init: float = 0.0,
) -> jax.Array:
    """Score every candidate ``u`` for being appended next (higher is better).

    Args:
      criterion: one of ``ng`` (Eq. 3.2), ``osa`` (3.3), ``tl`` (3.4-3.5),
        ``gml`` (3.6), ``lpg`` (3.7).
      p_next: ``[K]`` success probability from the tour's end to each candidate.
      p_pair: ``[K, K]`` success probability between candidates.
      beta: ``[K]`` rewards.
      mask: ``[K]`` bool, candidates still unassigned.
      p_end: reach probability of the tour's end ``P_t(e)`` (1 for a fresh start).
      lpg_init: the starting value of LPG's loss sum. Algorithm 7 writes
        ``+inf``, which makes every candidate tie; 0 (the default) is the
        reading consistent with Eq. 3.7.

    Returns:
      ``[K]`` scores, ``-inf`` where ``mask`` is false.
    """
    mask = jnp.asarray(mask, dtype=bool)
    gain = p_end * p_next * beta  # g(u), Eq. 3.2
    if criterion == "ng":
        score = gain
    elif criterion == "osa":
        # max over v != u of g(u) + p(u) p(u, v) beta(v); with no other v, just g(u).
        after, other = _pairwise(p_next, p_pair, beta, mask, p_end)
        two = jnp.where(other, after, -jnp.inf).max(axis=1)
        score = gain + jnp.where(jnp.isfinite(two), two, 0.0)
    elif criterion == "tl":
        score = -total_loss(p_next, p_pair, beta, mask, p_end)
    elif criterion == "gml":
        after, other = _pairwise(p_next, p_pair, beta, mask, p_end)
        delta = gain[None, :] - after  # Eq. 3.4
        min_loss = jnp.where(other, delta, jnp.inf).min(axis=1)
        score = gain - jnp.where(jnp.isfinite(min_loss), min_loss, 0.0)
    elif criterion == "lpg":
        total = lpg_init + total_loss(p_next, p_pair, beta, mask, p_end)
        # A candidate that cannot be reached (zero gain) is the worst valid choice;
        # clamping keeps every valid score above the -inf of masked candidates.
        ratio = jnp.where(gain > 0, total / jnp.where(gain > 0, gain, 1.0), jnp.inf)
        score = -jnp.minimum(ratio, jnp.finfo(jnp.float32).max)
    else:
        raise ValueError(f"criterion must be one of {APPEND_CRITERIA}, got {criterion!r}")
    return jnp.where(mask, score, -jnp.inf)
