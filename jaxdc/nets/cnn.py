"""A plain CNN actor-critic: ENN's body without heuristics (an ablation, not in the thesis).

Same body as ENN (section 4.5), with linear policy logits and value on top;
it shows how much the heuristics of section 4.4.3 contribute.
"""

from __future__ import annotations

from typing import Any

import jax

from jaxdc.nets.body import THESIS_FEATURES, THESIS_HIDDEN, THESIS_POOL, ConvBody
from jaxdc.nets.heads import LinearHeads


class CNN(LinearHeads):
    """``(obs [B, N, N, 2], heuristics ignored) -> (logits [B, A], value [B])``; ``body_features``,
    ``body_hidden`` and ``body_pool`` shape the body (ENN's by default)."""

    body_features: tuple[int, ...] = THESIS_FEATURES
    body_hidden: int = THESIS_HIDDEN
    body_pool: str = THESIS_POOL

    def setup(self) -> None:
        self.body = ConvBody(self.body_features, self.body_hidden, self.body_pool)
        super().setup()

    def features(self, obs: Any) -> jax.Array:
        return self.body(obs)
