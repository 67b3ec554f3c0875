"""The team DCG: ``k`` collectors against ``m`` opponents (the thesis' conclusion to chapter 5; issue 29).

* :mod:`jaxdc.dcg.team.state` -- the stacked state, the one-collector views, the limits and readings;
* :mod:`jaxdc.dcg.team.targeting` -- whom each opponent chases, and their simultaneous move;
* :mod:`jaxdc.dcg.team.observation` -- each collector's observation and the critic's world state;
* :mod:`jaxdc.dcg.team.env` -- the game (:class:`DCGTeam`);
* :mod:`jaxdc.dcg.team.picture` -- its text grid and drawn frames.
"""

from jaxdc.dcg.team.env import DCGTeam
from jaxdc.dcg.team.state import FOG_TARGETS, MAX_COLLECTORS, MAX_OPPONENTS, TARGET_TIES, TeamState

__all__ = ["DCGTeam", "TeamState", "MAX_COLLECTORS", "MAX_OPPONENTS", "FOG_TARGETS", "TARGET_TIES"]
