"""VNN and IMNN: the navigation networks of sections 5.4.2 and 5.4.3 (Figs. 5.2, 5.3).

Both are the plain actor-critic CNN of section 5.5.2 (:class:`jaxdc.nets.cnn.CNN`:
conv 3x3 32 -> conv 3x3 16 -> dense 256, a softmax policy and a linear value
sharing everything but their output layers); they differ only in the input
layer. The DCG observation is ``[N, N, 2 + k]``: ``M^item_t``, ``M^agent_t``,
then the history ``M^agent_{t-1} .. M^agent_{t-k}`` (:mod:`jaxdc.dcg.env`).

* **VNN** (5.4.2) reads the current state only: the first two channels.
  Changing the history channels does not change its output.
* **IMNN** (5.4.3) reads state and history: all ``2 + k`` channels. "IMNN has
  the same network structure as the VNN ... except for the input layer."

``state_channels`` (beyond the thesis) is 3 for the ``"general"`` observation
of :class:`jaxdc.dcg.env.DCG`, whose state adds the budget plane; 2 otherwise.
"""

from __future__ import annotations

from jaxdc.nets.cnn import CNN

#: Channels of the current state ``s_t`` (``M^item``, ``M^agent``) at the front of a DCG observation.
STATE_CHANNELS = 2


def check_history_channels(obs, history: int, name: str, state_channels: int = STATE_CHANNELS) -> None:
    """Raise a ``ValueError`` unless ``obs`` has ``state_channels + history`` channels (a static shape check,
    jit-safe)."""
    if obs.shape[-1] != state_channels + history:
        raise ValueError(f"{name} with history k={history} expects observations [B, N, N, {state_channels + history}] "
                         f"(state and history, DCG(history={history}, obs_history=True)), got {tuple(obs.shape)}")


class VNN(CNN):
    """Vanilla Navigation Network (section 5.4.2, Fig. 5.2): ``obs [B, N, N, >=2] -> (logits [B, A], value [B])``.

    Only ``obs[..., :state_channels]`` (the state ``s``) is read, so VNN cannot model the opponent.
    """

    state_channels: int = STATE_CHANNELS

    def __call__(self, obs, heuristics=None):
        return super().__call__(obs[..., :self.state_channels])

    def value(self, obs):
        """``V(s)``."""
        return super().value(obs[..., :self.state_channels])


class IMNN(CNN):
    """Implicit Modeling Navigation Network (section 5.4.3, Fig. 5.3): state and history ``[B, N, N, 2 + k]``.

    ``history`` (``k``, 10 in section 5.5.2) is checked against the observation's channels.
    """

    history: int = 10
    state_channels: int = STATE_CHANNELS

    def __call__(self, obs, heuristics=None):
        check_history_channels(obs, self.history, type(self).__name__, self.state_channels)
        return super().__call__(obs)

    def value(self, obs):
        """``V(s, h)``."""
        check_history_channels(obs, self.history, type(self).__name__, self.state_channels)
        return super().value(obs)
