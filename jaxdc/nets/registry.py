"""The networks of each problem by name: one registry per problem, read by loading, training and metadata.

Each entry is a :class:`NetEntry`: the network's class and the algorithm that
trains it (``"a2c"``: synchronous A2C, Algorithm 10; ``"nstep_q"``: n-step
Q-learning, section 4.5.5). Whether a network reads the heuristics of section
4.4.3 or has the opponent-action head of section 5.4 is its class attribute
(``uses_heuristics``, ``has_aux``), read through the entry. The registries
know no problem module: they are keyed by the problem's name (``"dcp"``,
``"dcg"``), and a new variant adds its networks here.

Beyond the thesis (issue 29, the team game of the conclusion to chapter 5): the team learners by name
(:data:`ALGOS`, ``train.dcg --algo``) and the centralised critics they train (:data:`CRITICS`; MAPPO's,
Yu et al. 2022), built by :func:`build_critic`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, cast

import flax.linen as nn

from jaxdc.core.validate import check_choice, is_int
from jaxdc.nets.body import THESIS_FEATURES, THESIS_HIDDEN, check_body, check_pool
from jaxdc.nets.cnn import CNN
from jaxdc.nets.critic import WorldCritic
from jaxdc.nets.emnn import EMNN
from jaxdc.nets.enn import ENN, HeuristicNet
from jaxdc.nets.eqn import EQN
from jaxdc.nets.linear import Linear
from jaxdc.nets.omn_conn import OMNCoNN
from jaxdc.nets.vnn import IMNN, VNN

#: The algorithms a registered network trains with.
A2C, NSTEP_Q = "a2c", "nstep_q"


@dataclasses.dataclass(frozen=True)
class NetEntry:
    """One registered network: its flax class and the algorithm that trains it."""

    cls: type[nn.Module]
    algorithm: str = A2C
    #: Whether the constructor takes ``history`` (the DCG networks that read ``k`` previous agent planes).
    takes_history: bool = False
    #: Whether the network has the convolutional body of section 4.5, sized by ``body_features`` and
    #: ``body_hidden``.
    takes_body: bool = False

    @property
    def uses_heuristics(self) -> bool:
        """Whether the network reads the heuristics of section 4.4.3 (a trainer computes them only then)."""
        return bool(cast(Any, self.cls).uses_heuristics)  # a class attribute flax's Module type does not declare

    @property
    def has_aux(self) -> bool:
        """Whether the network has the opponent-action head (EMNN, OMN + CoNN; section 5.4)."""
        return bool(cast(Any, self.cls).has_aux)


#: The DCP's networks (section 4.5), in the order of the thesis' tables: ENN, the linear learner, the CNN, EQN.
DCP_NETS: dict[str, NetEntry] = {"enn": NetEntry(ENN, takes_body=True), "linear": NetEntry(Linear),
                                 "cnn": NetEntry(CNN, takes_body=True), "eqn": NetEntry(EQN, NSTEP_Q, takes_body=True)}
#: The DCG's networks (section 5.4), in the order of the thesis' figures.
DCG_NETS: dict[str, NetEntry] = {"vnn": NetEntry(VNN), "imnn": NetEntry(IMNN, takes_history=True),
                                 "emnn": NetEntry(EMNN, takes_history=True),
                                 "omn_conn": NetEntry(OMNCoNN, takes_history=True)}
#: The registry of each problem.
REGISTRIES: dict[str, dict[str, NetEntry]] = {"dcp": DCP_NETS, "dcg": DCG_NETS}
#: The centralised critics by name (beyond the thesis): MAPPO's value network on the team's world state.
CRITICS: dict[str, type[nn.Module]] = {"world": WorldCritic}
#: The team learners (``train.dcg --algo``; beyond the thesis, issue 29) and the critic each trains: ``None`` --
#: each collector's own value head on its own observation (shared-parameter IPPO, the default), else a
#: centralised critic of :data:`CRITICS` on the world state (MAPPO, Yu et al. 2022).
ALGOS: dict[str, str | None] = {"ippo": None, "mappo": "world"}


def names(problem: str) -> tuple[str, ...]:
    """The names of ``problem``'s networks, in registry order."""
    return tuple(REGISTRIES[problem])


def entry(problem: str, name: str) -> NetEntry:
    """The entry of network ``name`` of ``problem``; ``ValueError`` listing the names for an unknown one."""
    nets = REGISTRIES[problem]
    if name not in nets:
        raise ValueError(f"net must be one of {tuple(nets)}, got {name!r}")
    return nets[name]


def body_options(problem: str, name: str, body_features: Any = None, body_hidden: Any = None,
                 body_pool: Any = None) -> dict[str, Any]:
    """The constructor options that shape network ``name``'s convolutional body (section 4.5; beyond the thesis):
    ``{}`` when all are ``None`` (the thesis' ``(32, 16)`` filters, 256 hidden units, the grid flattened), else
    ``{"body_features": tuple, "body_hidden": int}`` with the thesis' value for the one left ``None``, and
    ``"body_pool"`` when it is set (one of :data:`jaxdc.nets.body.POOLS`). Only ENN, EQN and the CNN have the body,
    and the sizes are bounded (:func:`jaxdc.nets.body.check_body`); else a ``TypeError``/``ValueError`` naming the
    parameter."""
    given = {n: v for n, v in (("body_features", body_features), ("body_hidden", body_hidden),
                               ("body_pool", body_pool)) if v is not None}
    if not given:
        return {}
    if not entry(problem, name).takes_body:
        shown = ", ".join(f"{n}={v!r}" for n, v in given.items())
        raise ValueError(f"{shown}: network {name!r} has no convolutional body to size (ENN, EQN and the CNN "
                         f"have one)")
    out: dict[str, Any] = {}
    if body_features is not None or body_hidden is not None:
        features, hidden = check_body(THESIS_FEATURES if body_features is None else body_features,
                                      THESIS_HIDDEN if body_hidden is None else body_hidden)
        out.update(body_features=features, body_hidden=hidden)
    if body_pool is not None:
        out["body_pool"] = check_pool(body_pool)
    return out


def build(problem: str, name: str, history: int = 10, num_heuristics: int = 10, num_actions: int = 9,
          state_channels: int = 2, body_features: Sequence[int] | None = None,
          body_hidden: int | None = None, body_pool: str | None = None) -> nn.Module:
    """The flax module of network ``name`` of ``problem``.

    A DCG network that reads history planes needs ``history >= 1`` (section 5.5.2: ``k = 10``); VNN and the DCP's
    networks ignore it. ENN and EQN combine ``num_heuristics`` heuristics (section 4.4.3). A DCG network reads
    ``state_channels`` state planes before the history (2; 3 for the ``"general"`` observation's budget plane).
    ``body_features`` (filter counts) and ``body_hidden`` (units) size the convolutional body of ENN, EQN and the CNN
    (``None``: the thesis' ``(32, 16)`` and 256; beyond the thesis, :func:`body_options`), and ``body_pool`` how it
    reduces the grid (``None``: flattened, the thesis; ``"mean_max"``: pooled, for every grid size); another
    network has no such body and refuses them.
    """
    e = entry(problem, name)
    sized = body_options(problem, name, body_features, body_hidden, body_pool)
    if problem == "dcg" and state_channels not in (2, 3):
        raise ValueError(f"state_channels must be 2 (thesis) or 3 (general observation), got {state_channels!r}")
    extra = {} if state_channels == 2 else {"state_channels": state_channels}
    if e.takes_history:
        if not is_int(history, numpy=False) or history < 1:
            raise ValueError(f"history (k) must be an int >= 1 for {name}, got {history!r}")
        return e.cls(num_actions, history=history, **extra)
    if problem == "dcg":
        return e.cls(num_actions, **extra)
    if issubclass(e.cls, HeuristicNet):  # ENN, EQN
        return e.cls(num_heuristics, num_actions, **sized)
    return e.cls(num_actions, **sized)


def build_critic(algo: str) -> nn.Module | None:
    """The centralised critic that team learner ``algo`` (one of :data:`ALGOS`) trains, ``None`` for IPPO (the
    collectors' own value heads); ``ValueError`` naming ``algo`` and the allowed values for another."""
    name = ALGOS[check_choice("algo", algo, tuple(ALGOS))]
    return None if name is None else CRITICS[name]()
