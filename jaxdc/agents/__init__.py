"""Learning algorithms only (no networks, no problems): synchronous A2C (Algorithm 10) and n-step Q-learning."""

from __future__ import annotations

from jaxdc.agents.a2c import (
    A2CConfig,
    Trainer,
    TrainState,
    a2c_loss,
    huber,
    lr_schedule,
    make_optimizer,
    make_policy,
    make_train,
    nstep_returns,
)
from jaxdc.agents.nstep_q import QConfig, QTrainState, epsilon_greedy, make_q_policy

__all__ = ["A2CConfig", "TrainState", "Trainer", "a2c_loss", "huber", "lr_schedule", "make_optimizer",
           "make_policy", "make_train", "nstep_returns", "QConfig", "QTrainState", "epsilon_greedy", "make_q_policy"]
