"""The linear learner of section 4.5.5 (Table 4.9).

"This learner uses a linear function to approximate the policy
pi(a|s; theta), and another linear function to approximate the state-only
value function V(s; theta_v)" -- both on the flattened two planes, with no
heuristics.
"""

from __future__ import annotations

import flax.linen as nn
import jax.numpy as jnp


class Linear(nn.Module):
    """``(obs [B, N, N, C], heuristics ignored) -> (logits [B, A], value [B])``, both linear in ``obs``."""

    num_actions: int = 9
    uses_heuristics = False
    has_aux = False
    aux_params = ()

    def setup(self):
        self.policy_out = nn.Dense(self.num_actions)
        self.value_out = nn.Dense(1)

    def _flat(self, obs):
        obs = jnp.asarray(obs, jnp.float32)
        return obs.reshape(obs.shape[0], -1)

    def __call__(self, obs, heuristics=None):
        x = self._flat(obs)
        return self.policy_out(x), self.value_out(x)[:, 0]

    def value(self, obs):
        return self.value_out(self._flat(obs))[:, 0]
