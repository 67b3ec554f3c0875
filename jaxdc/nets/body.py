"""The shared convolutional body of ENN, EQN and the plain CNN (section 4.5).

"ENN has two convolutional layers, all of which have filters of size 3 x 3
and strides of size 1 with same paddings. The filter counts are 32 and 16 in
that order. The fully connected layer has 256 hidden units. All the hidden
layers are followed by rectifier nonlinearity."
"""

from __future__ import annotations

from typing import Sequence

import flax.linen as nn
import jax.numpy as jnp


class ConvBody(nn.Module):
    """``obs [B, N, N, C] -> features [B, hidden]``: conv 3x3 (same) x len(features), then dense, all ReLU."""

    features: Sequence[int] = (32, 16)
    hidden: int = 256

    @nn.compact
    def __call__(self, obs):
        x = jnp.asarray(obs, jnp.float32)
        for f in self.features:
            x = nn.relu(nn.Conv(f, (3, 3), strides=1, padding="SAME")(x))
        x = x.reshape(x.shape[0], -1)
        return nn.relu(nn.Dense(self.hidden)(x))
