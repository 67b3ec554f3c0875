"""EMNN: explicit opponent modelling in the same network (section 5.4.4, Fig. 5.4, Algorithm 11).

IMNN (:class:`jaxdc.nets.vnn.IMNN`) plus a third output layer on the shared
features: the opponent-action prediction ``pi^o(s, h; theta_o)``. "theta,
theta_v and theta_o share the same parameters except for those in the output
layer." It is trained with the A2C loss plus ``alpha`` times the
cross-entropy of ``pi^o`` against the opponent's action ``o_t`` (Eq. 5.1):
``has_aux = True`` makes :func:`jaxdc.agents.a2c.make_train` add
``A2CConfig.aux_coef`` (= ``alpha``: 0.001, or 0.0001) times that term, with
``aux_target=lambda info: info["opponent_action"]``. The prediction is not
used to act (section 5.4.6); it only shapes the shared parameters.
"""

from __future__ import annotations

import flax.linen as nn

from jaxdc.nets.vnn import IMNN, check_history_channels


class EMNN(IMNN):
    """``obs [B, N, N, 2 + k] -> (logits [B, A], value [B], opponent_logits [B, A])`` (Fig. 5.4)."""

    has_aux = True

    def setup(self):
        super().setup()
        self.opponent_out = nn.Dense(self.num_actions)

    def __call__(self, obs, heuristics=None):
        check_history_channels(obs, self.history, type(self).__name__, self.state_channels)
        h = self.body(obs)
        return self.policy_out(h), self.value_out(h)[:, 0], self.opponent_out(h)
