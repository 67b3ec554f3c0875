"""OMN + CoNN: explicit opponent modelling with a separate network (section 5.4.5, Fig. 5.5, Algorithm 12).

* **OMN** (Opponent Modeling Network): the hidden layers of VNN (section
  5.5.2's body) on state and history, with one output layer: the prediction
  ``pi^o(s, h; theta_o)`` of the opponent's action ``o_t``. Its loss is the
  cross-entropy of Eq. 5.1 alone.
* **CoNN** (Cooperating Navigation Network): the same hidden layers, with the
  policy and value outputs, reading state, history and OMN's prediction. Its
  loss is IMNN's (the A2C loss).

How CoNN reads ``pi^o``: the thesis says only that OMN's output, "combined
with s and h, ... is used as input" to CoNN. Here the 9 probabilities
``softmax(OMN logits)`` are broadcast to 9 constant ``N x N`` planes and
concatenated to the observation, so CoNN's input layer is
``[B, N, N, 2 + k + 9]`` and it otherwise is IMNN. A ``stop_gradient`` on that
input means no gradient of CoNN's loss reaches OMN: OMN learns only from its
cross-entropy, as Algorithm 12 says.

One flax module holds both networks and returns OMN's logits as its auxiliary
output (``has_aux = True``); train it with :func:`jaxdc.agents.a2c.make_train`,
``aux_target=lambda info: info["opponent_action"]`` and ``aux_coef = 1``. The
summed loss ``L_CoNN(theta, theta_v) + CE(theta_o)`` then has gradient
``dL_CoNN`` on CoNN's parameters and ``dCE`` on OMN's (the two parameter
sets are disjoint and the stop-gradient cuts the only path between them).
Adam is element-wise: each parameter's update depends only on its own
gradient history and the shared learning-rate schedule. So one Adam on the
union is exactly two Adams, one per network, each on its own loss with the
same schedule -- the two updates of Algorithm 12. (This fails with a global
gradient-norm clip, which couples the two; ``A2CConfig.max_grad_norm`` is off
by default.) Because the two Adams are separate, OMN may also get its own
initial learning rate (``A2CConfig.aux_lr``, ``train.dcg --omn-lr``; an option,
not in the thesis): ``aux_params = ("omn",)`` names its parameters.
"""

from __future__ import annotations

import flax.linen as nn
import jax
import jax.numpy as jnp

from jaxdc.nets.body import ConvBody
from jaxdc.nets.cnn import CNN
from jaxdc.nets.vnn import STATE_CHANNELS, check_history_channels


def prediction_planes(obs, opponent_logits):
    """``[B, N, N, C + A]``: ``obs`` with the probabilities ``softmax(opponent_logits)`` as ``A`` constant planes.

    The probabilities are held constant (``stop_gradient``): CoNN's loss does not train OMN (Algorithm 12).
    """
    p = jax.lax.stop_gradient(jax.nn.softmax(opponent_logits))
    planes = jnp.broadcast_to(p[:, None, None, :], obs.shape[:-1] + p.shape[-1:])
    return jnp.concatenate([jnp.asarray(obs, jnp.float32), planes], axis=-1)


class OMN(nn.Module):
    """Opponent Modeling Network: ``obs [B, N, N, 2 + k] -> opponent logits [B, A]`` (Fig. 5.5, left)."""

    num_actions: int = 9

    @nn.compact
    def __call__(self, obs):
        return nn.Dense(self.num_actions, name="opponent_out")(ConvBody(name="body")(obs))


class OMNCoNN(nn.Module):
    """OMN and CoNN: ``obs [B, N, N, 2 + k] -> (logits [B, A], value [B], opponent_logits [B, A])`` (Fig. 5.5)."""

    num_actions: int = 9
    history: int = 10
    state_channels: int = STATE_CHANNELS  # 3: the general observation's budget plane (beyond the thesis)
    uses_heuristics = False
    has_aux = True
    #: OMN's parameters (top-level name), for a separate learning rate (``A2CConfig.aux_lr``; not in the thesis).
    aux_params = ("omn",)

    def setup(self):
        self.omn = OMN(self.num_actions)
        self.conn = CNN(self.num_actions)  # IMNN's layers on the wider input

    def __call__(self, obs, heuristics=None):
        check_history_channels(obs, self.history, type(self).__name__, self.state_channels)
        opponent_logits = self.omn(obs)
        logits, value = self.conn(prediction_planes(obs, opponent_logits))
        return logits, value, opponent_logits

    def value(self, obs):
        """``V(s, h, pi^o(s, h))``."""
        check_history_channels(obs, self.history, type(self).__name__, self.state_channels)
        return self.conn.value(prediction_planes(obs, self.omn(obs)))
