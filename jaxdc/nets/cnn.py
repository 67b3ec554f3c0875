"""A plain CNN actor-critic: ENN's body without heuristics (an ablation, not in the thesis).

Same body as ENN (section 4.5), with linear policy logits and value on top;
it shows how much the heuristics of section 4.4.3 contribute.
"""

from __future__ import annotations

import flax.linen as nn

from jaxdc.nets.body import ConvBody


class CNN(nn.Module):
    """``(obs [B, N, N, 2], heuristics ignored) -> (logits [B, A], value [B])``."""

    num_actions: int = 9
    uses_heuristics = False
    has_aux = False
    aux_params = ()

    def setup(self):
        self.body = ConvBody()
        self.policy_out = nn.Dense(self.num_actions)
        self.value_out = nn.Dense(1)

    def __call__(self, obs, heuristics=None):
        h = self.body(obs)
        return self.policy_out(h), self.value_out(h)[:, 0]

    def value(self, obs):
        return self.value_out(self.body(obs))[:, 0]
