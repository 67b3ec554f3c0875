"""Linear policy and value heads on a feature map, for the learners without heuristics (section 4.5.5's linear
learner and the plain CNN ablation).

A subclass says how ``obs`` becomes features (its ``features(obs)`` method); the heads, the call and
``value`` are shared. Neither reads ENN's heuristics (``uses_heuristics = False``).
"""

from __future__ import annotations

from typing import Any

import flax.linen as nn
import jax


class LinearHeads(nn.Module):
    """``(obs [B, N, N, C], heuristics ignored) -> (logits [B, A], value [B])``: linear in ``features(obs)``."""

    num_actions: int = 9
    uses_heuristics = False
    has_aux = False
    aux_params = ()

    def setup(self) -> None:
        self.policy_out = nn.Dense(self.num_actions)
        self.value_out = nn.Dense(1)

    def features(self, obs: Any) -> jax.Array:
        """``obs [B, ...] -> [B, F]``: what the heads read (written by each subclass)."""
        raise NotImplementedError

    def __call__(self, obs: Any, heuristics: Any = None) -> tuple[jax.Array, jax.Array]:
        h = self.features(obs)
        return self.policy_out(h), self.value_out(h)[:, 0]

    def value(self, obs: Any) -> jax.Array:
        return self.value_out(self.features(obs))[:, 0]
