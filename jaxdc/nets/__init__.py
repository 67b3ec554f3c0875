"""Flax networks (linen), one module per file; no algorithm lives here.

Every actor-critic network maps ``(obs [B, N, N, 2], heuristics [B, 10, 9])``
to ``(logits [B, 9], value [B])`` and has a ``value(obs)`` method; the class
attribute ``uses_heuristics`` tells a trainer whether it must compute the
heuristics at all. :class:`EQN` (Fig. 4.4) maps the same inputs to Q-values
``[B, 9]`` and is not an actor-critic. Every network declares the attributes
a trainer reads, :class:`jaxdc.agents.common.Network`: ``num_actions``,
``uses_heuristics``, ``has_aux`` and ``aux_params`` (class attributes, not
flax fields).

The DCG networks of section 5.4 (:data:`DCG_NETS`, :func:`make_dcg_net`) read
DCG observations ``[B, N, N, 2 + k]`` and use no heuristics; EMNN and
OMN + CoNN (``has_aux = True``) return a third output, the opponent-action
logits ``[B, 9]``.
"""

from __future__ import annotations

from jaxdc.core.validate import is_int
from jaxdc.nets.body import ConvBody
from jaxdc.nets.cnn import CNN
from jaxdc.nets.enn import ENN, EnsembleHead, ensemble
from jaxdc.nets.emnn import EMNN
from jaxdc.nets.eqn import EQN
from jaxdc.nets.linear import Linear
from jaxdc.nets.omn_conn import OMN, OMNCoNN
from jaxdc.nets.vnn import IMNN, VNN

#: Actor-critic networks by the name used on the command line.
ACTOR_CRITICS = {"enn": ENN, "linear": Linear, "cnn": CNN}


def make_net(name: str, num_heuristics: int = 10, num_actions: int = 9):
    """The actor-critic network called ``name`` (one of :data:`ACTOR_CRITICS`)."""
    if name not in ACTOR_CRITICS:
        raise ValueError(f"net must be one of {tuple(ACTOR_CRITICS)}, got {name!r}")
    if name == "enn":
        return ENN(num_heuristics, num_actions)
    return ACTOR_CRITICS[name](num_actions)


#: The DCG networks of section 5.4 by the name used on the command line.
DCG_NETS = {"vnn": VNN, "imnn": IMNN, "emnn": EMNN, "omn_conn": OMNCoNN}


def make_dcg_net(name: str, history: int = 10, num_actions: int = 9):
    """The DCG network called ``name`` (one of :data:`DCG_NETS`, section 5.4) for a history of ``k = history``.

    VNN reads only the current state and ignores ``history``; the others need ``history >= 1``
    (section 5.5.2: ``k = 10``).
    """
    if name not in DCG_NETS:
        raise ValueError(f"net must be one of {tuple(DCG_NETS)}, got {name!r}")
    if name == "vnn":
        return VNN(num_actions)
    if not is_int(history, numpy=False) or history < 1:
        raise ValueError(f"history (k) must be an int >= 1 for {name}, got {history!r}")
    return DCG_NETS[name](num_actions, history=history)


__all__ = ["ACTOR_CRITICS", "CNN", "ConvBody", "DCG_NETS", "EMNN", "ENN", "EQN", "EnsembleHead", "IMNN", "Linear",
           "OMN", "OMNCoNN", "VNN", "ensemble", "make_dcg_net", "make_net"]
