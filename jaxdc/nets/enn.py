"""The Ensemble Navigation Network, ENN (section 4.4.3, Fig. 4.3).

The CNN body reads the two planes ``M^item`` and ``M^agent`` and outputs one
weight vector ``w_i(s)`` per heuristic, a bias ``b(s)`` and a value
``V(s)``; the policy is

    pi(s) = softmax( sum_i w_i(s) * H_i(s) + b(s) )        (section 4.4.3)

with ``*`` the element-wise product and ``H_i(s)`` the ten heuristic action
vectors of :func:`jaxdc.dcp.navigators.enn_heuristics`. Policy and value
share every parameter except their output layers.
"""

from __future__ import annotations

import flax.linen as nn
import jax.numpy as jnp

from jaxdc.nets.body import THESIS_FEATURES, THESIS_HIDDEN, THESIS_POOL, ConvBody


def ensemble(weights, bias, heuristics):
    """``sum_i w_i * H_i + b``: ``weights [B, n, A]``, ``bias [B, A]``, ``heuristics [B, n, A]`` -> ``[B, A]``."""
    return jnp.sum(weights * heuristics, axis=-2) + bias


class EnsembleHead(nn.Module):
    """Features -> ``(w [B, n, A], b [B, A])``: the linear output layer of Figs. 4.3 and 4.4.

    ``w`` and ``b`` are sown (as ``"w"`` and ``"b"``) into the ``"intermediates"`` collection, so
    ``apply(..., mutable=["intermediates"])`` exposes them.
    """

    num_heuristics: int = 10
    num_actions: int = 9

    @nn.compact
    def __call__(self, features):
        n, a = self.num_heuristics, self.num_actions
        w = nn.Dense(n * a, name="weights")(features).reshape(features.shape[0], n, a)
        b = nn.Dense(a, name="bias")(features)
        self.sow("intermediates", "w", w)
        self.sow("intermediates", "b", b)
        return w, b


class HeuristicNet(nn.Module):
    """The fields and the network contract of the networks that weigh the heuristic vectors (ENN, EQN).

    ``body_features`` and ``body_hidden`` size the convolutional body (:class:`~jaxdc.nets.body.ConvBody`) and
    ``body_pool`` says how it reduces the grid; the defaults are the thesis' (section 4.5), a wider body or a
    pooled one (which fits every grid size) is an option beyond it.
    """

    num_heuristics: int = 10
    num_actions: int = 9
    body_features: tuple[int, ...] = THESIS_FEATURES
    body_hidden: int = THESIS_HIDDEN
    body_pool: str = THESIS_POOL
    uses_heuristics = True
    has_aux = False
    aux_params = ()


class ENN(HeuristicNet):
    """``(obs [B, N, N, 2], heuristics [B, n, A]) -> (logits [B, A], value [B])`` (Fig. 4.3)."""

    def setup(self):
        self.body = ConvBody(self.body_features, self.body_hidden, self.body_pool)
        self.head = EnsembleHead(self.num_heuristics, self.num_actions)
        self.value_out = nn.Dense(1)

    def __call__(self, obs, heuristics):
        h = self.body(obs)
        w, b = self.head(h)
        return ensemble(w, b, heuristics), self.value_out(h)[:, 0]

    def value(self, obs):
        """``V(s)`` alone (it does not depend on the heuristics)."""
        return self.value_out(self.body(obs))[:, 0]
