"""The Data-collection Game (thesis chapter 5): the environment and its opponent strategies."""

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
