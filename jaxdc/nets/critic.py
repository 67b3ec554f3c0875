"""The centralised critic of MAPPO: a value network on the team game's world state (beyond the thesis).

The thesis trains one collector (chapter 5); its conclusion to chapter 5 proposes several cooperating
collectors, which jaxdc plays as the team game (:class:`jaxdc.dcg.team.DCGTeam`, issue 29). Its learners
("3. Learners" of issue 29) are IPPO -- one actor-critic shared by the collectors, each critic reading its own
observation -- and MAPPO (Yu et al. 2022, "The Surprising Effectiveness of PPO in Cooperative Multi-Agent
Games"), whose critic is *centralised*: during training it reads the global state, while every actor still acts
on its own observation. This module is that critic: ``world [B, N, N, C] -> value [B]``, the section-4.5 body
(:class:`~jaxdc.nets.body.ConvBody`: conv 3x3 32, conv 3x3 16, dense 256, ReLU) and a linear value output, on
:meth:`jaxdc.dcg.team.observation.TeamObservation.world_state` (items, every collector's energy at its cell, the
opponents, unhidden; the budget plane with the ``"general"`` observation).

It is a separate network with its own parameters (the trainer keeps them in the trained parameter tree,
:mod:`jaxdc.agents.centralised`); it reads no heuristics and has no auxiliary head. It is only for training:
the actor alone plays.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import flax.linen as nn
import jax

from jaxdc.nets.body import ConvBody


class WorldCritic(nn.Module):
    """MAPPO's centralised critic (Yu et al. 2022): ``world [B, N, N, C] -> V(world) [B]`` (module docs)."""

    features: Sequence[int] = (32, 16)
    hidden: int = 256
    uses_heuristics = False
    has_aux = False
    aux_params = ()

    @nn.compact
    def __call__(self, world: Any) -> jax.Array:
        h = ConvBody(self.features, self.hidden, name="body")(world)
        return nn.Dense(1, name="value_out")(h)[:, 0]
