"""The linear learner of section 4.5.5 (Table 4.9).

"This learner uses a linear function to approximate the policy
pi(a|s; theta), and another linear function to approximate the state-only
value function V(s; theta_v)" -- both on the flattened two planes, with no
heuristics.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from jaxdc.nets.heads import LinearHeads


class Linear(LinearHeads):
    """``(obs [B, N, N, C], heuristics ignored) -> (logits [B, A], value [B])``, both linear in ``obs``."""

    def features(self, obs: Any) -> jax.Array:
        obs = jnp.asarray(obs, jnp.float32)
        return obs.reshape(obs.shape[0], -1)
