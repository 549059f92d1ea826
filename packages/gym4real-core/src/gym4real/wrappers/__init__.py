"""Wrappers for every Gym4ReaL environment: multi-objective rewards, safe-RL costs, real-world challenges."""

from __future__ import annotations

from gym4real.wrappers.challenges import (
    LEVELS,
    ActionDelay,
    ActionPersistence,
    ExogenousPerturbation,
    ObservationDelay,
    ObservationNoise,
    SensorDropout,
    challenge,
)
from gym4real.wrappers.multi_objective import MultiObjective
from gym4real.wrappers.safety import SafetyCost

__all__ = [
    "LEVELS",
    "ActionDelay",
    "ActionPersistence",
    "ExogenousPerturbation",
    "MultiObjective",
    "ObservationDelay",
    "ObservationNoise",
    "SafetyCost",
    "SensorDropout",
    "challenge",
]
