"""The Data-collection Game (thesis chapter 5): the environment and its opponent strategies.

Beside the game: :mod:`jaxdc.dcg.evaluate` (batched evaluation), :mod:`jaxdc.dcg.learned` (trained
collectors), :mod:`jaxdc.dcg.exact` (full-information yardsticks) and :mod:`jaxdc.dcg.analysis`
(the section-5.5 experiments and claims).
"""

from jaxdc.dcg.env import DCG, OUTCOMES, EnvParams, EnvState
from jaxdc.dcg.opponents import (
    CHASE_TIES,
    DOUBLE_BLIND_STRATEGIES,
    STANDARD_STRATEGIES,
    OpponentState,
    register_strategy,
    registered_strategies,
)

__all__ = ["DCG", "OUTCOMES", "EnvParams", "EnvState", "OpponentState", "CHASE_TIES", "STANDARD_STRATEGIES",
           "DOUBLE_BLIND_STRATEGIES", "register_strategy", "registered_strategies"]
