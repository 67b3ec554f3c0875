"""Learning algorithms only (no networks, no problems): synchronous A2C (Algorithm 10) and n-step Q-learning.

:mod:`jaxdc.agents.common` holds what both share (settings, returns, optimizer, the networks' contract).
"""

from __future__ import annotations

from jaxdc.agents.a2c import A2CConfig, TrainState, a2c_loss, make_optimizer, make_policy, make_train
from jaxdc.agents.common import Network, RunConfig, Trainer, Transition, huber, lr_schedule, nstep_returns
from jaxdc.agents.nstep_q import QConfig, QTrainState, epsilon_greedy, make_q_policy

__all__ = ["A2CConfig", "Network", "RunConfig", "TrainState", "Trainer", "Transition", "a2c_loss", "huber",
           "lr_schedule", "make_optimizer", "make_policy", "make_train", "nstep_returns", "QConfig", "QTrainState",
           "epsilon_greedy", "make_q_policy"]
