"""Flax networks (linen), one module per file; no algorithm lives here.

Every actor-critic network maps ``(obs [B, N, N, 2], heuristics [B, 10, 9])``
to ``(logits [B, 9], value [B])`` and has a ``value(obs)`` method; the class
attribute ``uses_heuristics`` tells a trainer whether it must compute the
heuristics at all. :class:`EQN` (Fig. 4.4) maps the same inputs to Q-values
``[B, 9]`` and is not an actor-critic.
"""

from __future__ import annotations

from jaxdc.nets.body import ConvBody
from jaxdc.nets.cnn import CNN
from jaxdc.nets.enn import ENN, EnsembleHead, ensemble
from jaxdc.nets.eqn import EQN
from jaxdc.nets.linear import Linear

#: Actor-critic networks by the name used on the command line.
ACTOR_CRITICS = {"enn": ENN, "linear": Linear, "cnn": CNN}


def make_net(name: str, num_heuristics: int = 10, num_actions: int = 9):
    """The actor-critic network called ``name`` (one of :data:`ACTOR_CRITICS`)."""
    if name not in ACTOR_CRITICS:
        raise ValueError(f"net must be one of {tuple(ACTOR_CRITICS)}, got {name!r}")
    if name == "enn":
        return ENN(num_heuristics, num_actions)
    return ACTOR_CRITICS[name](num_actions)


__all__ = ["ACTOR_CRITICS", "CNN", "ConvBody", "ENN", "EQN", "EnsembleHead", "Linear", "ensemble", "make_net"]
