"""The Ensemble Q Network, EQN (section 4.5.5, Fig. 4.4).

"The same as that of ENN except for the final output": the CNN body gives a
weight vector ``w_i(s)`` per heuristic and a bias ``b(s)``, and

    Q(s, . ) = sum_i w_i(s) * H_i(s) + b(s)

estimates the state-action values (no separate value head). The thesis
trains it with asynchronous n-step Q-learning [25] and evaluates it
epsilon-greedily with epsilon = 0.05.
"""

from __future__ import annotations

import flax.linen as nn

from jaxdc.nets.body import ConvBody
from jaxdc.nets.enn import EnsembleHead, HeuristicNet, ensemble


class EQN(HeuristicNet):
    """``(obs [B, N, N, 2], heuristics [B, n, A]) -> q [B, A]`` (Fig. 4.4)."""

    @nn.compact
    def __call__(self, obs, heuristics):
        features = ConvBody(self.body_features, self.body_hidden, self.body_pool, name="body")(obs)
        w, b = EnsembleHead(self.num_heuristics, self.num_actions, name="head")(features)
        return ensemble(w, b, heuristics)
