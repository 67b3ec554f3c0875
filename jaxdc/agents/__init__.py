"""Learning algorithms only (no networks, no problems): synchronous A2C of Algorithm 10."""

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

__all__ = ["A2CConfig", "TrainState", "Trainer", "a2c_loss", "huber", "lr_schedule", "make_optimizer",
           "make_policy", "make_train", "nstep_returns"]
