"""The shared convolutional body of ENN, EQN and the plain CNN (section 4.5).

"ENN has two convolutional layers, all of which have filters of size 3 x 3
and strides of size 1 with same paddings. The filter counts are 32 and 16 in
that order. The fully connected layer has 256 hidden units. All the hidden
layers are followed by rectifier nonlinearity."

Beyond the thesis, the body may pool its last convolutional layer over the cells instead of flattening it
(``pool="mean_max"``: the mean and the maximum of each filter over the grid). Its parameters then do not depend on
the grid size, so one network plays every ``N x N`` grid (issue 28's stretch goal; docs/generalisation.md).
"""

from __future__ import annotations

from typing import Any, Sequence

import flax.linen as nn
import jax.numpy as jnp

from jaxdc.core.validate import check_choice, check_int

#: The thesis' body (section 4.5): the filter counts of the two convolutional layers and the hidden units.
THESIS_FEATURES: tuple[int, ...] = (32, 16)
THESIS_HIDDEN = 256
#: The bounds of an optional body (beyond the thesis): up to this many convolutional layers, each and the hidden
#: layer at most :data:`MAX_WIDTH` units wide (a guard against a typo that would not fit in memory).
MAX_CONV_LAYERS, MAX_WIDTH = 6, 4096
#: How the body turns the last convolutional layer into one vector: ``"flatten"`` (the thesis: every cell's
#: filters, so the dense layer's shape depends on the grid size) or ``"mean_max"`` (beyond the thesis: each
#: filter's mean and maximum over the cells, so the parameters fit every grid size).
POOLS = ("flatten", "mean_max")
THESIS_POOL = "flatten"
#: The pools whose parameters do not depend on the grid size.
GRID_FREE_POOLS = frozenset({"mean_max"})


def check_pool(body_pool: Any) -> str:
    """``body_pool`` if it is one of :data:`POOLS`, else a ``ValueError`` naming it and the choices."""
    return check_choice("body_pool", body_pool, POOLS)


def check_body(body_features: Any, body_hidden: Any) -> tuple[tuple[int, ...], int]:
    """``(body_features, body_hidden)``, the ``features`` and ``hidden`` of a :class:`ConvBody`, as ``(tuple of
    ints, int)``: 1..:data:`MAX_CONV_LAYERS` filter counts and a hidden width, each in ``1..MAX_WIDTH``; else a
    ``TypeError``/``ValueError`` naming the parameter."""
    if isinstance(body_features, (str, bytes)) or not isinstance(body_features, Sequence):
        raise TypeError(f"body_features must be a sequence of 1..{MAX_CONV_LAYERS} filter counts, "
                        f"got {body_features!r}")
    if not 1 <= len(body_features) <= MAX_CONV_LAYERS:
        raise ValueError(f"body_features must hold 1..{MAX_CONV_LAYERS} filter counts, got {len(body_features)}: "
                         f"{list(body_features)!r}")
    features = tuple(check_int(f"body_features[{i}]", f, 1, MAX_WIDTH) for i, f in enumerate(body_features))
    return features, check_int("body_hidden", body_hidden, 1, MAX_WIDTH)


class ConvBody(nn.Module):
    """``obs [B, N, N, C] -> features [B, hidden]``: conv 3x3 (same) x len(features), then ``pool`` (one of
    :data:`POOLS`), then dense, all ReLU."""

    features: Sequence[int] = THESIS_FEATURES
    hidden: int = THESIS_HIDDEN
    pool: str = THESIS_POOL

    @nn.compact
    def __call__(self, obs):
        x = jnp.asarray(obs, jnp.float32)
        for f in self.features:
            x = nn.relu(nn.Conv(f, (3, 3), strides=1, padding="SAME")(x))
        if self.pool == "mean_max":
            x = jnp.concatenate([jnp.mean(x, axis=(1, 2)), jnp.max(x, axis=(1, 2))], axis=-1)
        else:
            x = x.reshape(x.shape[0], -1)
        return nn.relu(nn.Dense(self.hidden)(x))
