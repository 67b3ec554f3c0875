"""Flax networks (linen), one module per file; no algorithm lives here.

Every actor-critic network maps ``(obs [B, N, N, 2], heuristics [B, 10, 9])``
to ``(logits [B, 9], value [B])`` and has a ``value(obs)`` method; the class
attribute ``uses_heuristics`` tells a trainer whether it must compute the
heuristics at all. :class:`EQN` (Fig. 4.4) maps the same inputs to Q-values
``[B, 9]`` and is not an actor-critic. Every network declares the attributes
a trainer reads, :class:`jaxdc.agents.common.Network`: ``num_actions``,
``uses_heuristics``, ``has_aux`` and ``aux_params`` (class attributes, not
flax fields).

The networks of each problem are registered by name in :mod:`jaxdc.nets.registry`
(:data:`~jaxdc.nets.registry.DCP_NETS`, :data:`~jaxdc.nets.registry.DCG_NETS`: class and training algorithm), which
loading, training and metadata read. The DCG networks of section 5.4 (:func:`make_dcg_net`) read
DCG observations ``[B, N, N, 2 + k]`` and use no heuristics; EMNN and
OMN + CoNN (``has_aux = True``) return a third output, the opponent-action
logits ``[B, 9]``.
"""

from __future__ import annotations

import flax.linen as nn

from jaxdc.nets.body import ConvBody
from jaxdc.nets.cnn import CNN
from jaxdc.nets.emnn import EMNN
from jaxdc.nets.enn import ENN, EnsembleHead, ensemble
from jaxdc.nets.eqn import EQN
from jaxdc.nets.linear import Linear
from jaxdc.nets.omn_conn import OMN, OMNCoNN
from jaxdc.nets.registry import A2C, DCG_NETS, DCP_NETS, NSTEP_Q, REGISTRIES, NetEntry, build
from jaxdc.nets.vnn import IMNN, VNN

#: The DCP's actor-critic networks (trained by A2C) by name: the ``"a2c"`` entries of
#: :data:`~jaxdc.nets.registry.DCP_NETS`.
ACTOR_CRITICS = {name: e.cls for name, e in DCP_NETS.items() if e.algorithm == A2C}


def make_net(name: str, num_heuristics: int = 10, num_actions: int = 9) -> nn.Module:
    """The DCP actor-critic network called ``name`` (one of :data:`ACTOR_CRITICS`)."""
    if name not in ACTOR_CRITICS:
        raise ValueError(f"net must be one of {tuple(ACTOR_CRITICS)}, got {name!r}")
    return build("dcp", name, num_heuristics=num_heuristics, num_actions=num_actions)


def make_dcg_net(name: str, history: int = 10, num_actions: int = 9) -> nn.Module:
    """The DCG network called ``name`` (one of :data:`~jaxdc.nets.registry.DCG_NETS`, section 5.4) for a history
    of ``k = history``.

    VNN reads only the current state and ignores ``history``; the others need ``history >= 1``
    (section 5.5.2: ``k = 10``).
    """
    return build("dcg", name, history=history, num_actions=num_actions)


__all__ = ["A2C", "ACTOR_CRITICS", "CNN", "ConvBody", "DCG_NETS", "DCP_NETS", "EMNN", "ENN", "EQN", "EnsembleHead",
           "IMNN", "Linear", "NSTEP_Q", "NetEntry", "OMN", "OMNCoNN", "REGISTRIES", "VNN", "build", "ensemble",
           "make_dcg_net", "make_net"]
