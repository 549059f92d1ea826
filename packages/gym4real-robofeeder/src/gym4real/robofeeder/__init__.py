"""RoboFeeder of Gym4ReaL. Re-exports are lazy: the plugin module imports this package at discovery."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gym4real.robofeeder.config import PickingConfig, PlanningConfig, RoboFeederConfig
    from gym4real.robofeeder.env import RoboFeederPickingEnv, RoboFeederPickingImageEnv
    from gym4real.robofeeder.planning import RoboFeederPlanningEnv

_LAZY = {
    "RoboFeederPickingEnv": "gym4real.robofeeder.env",
    "RoboFeederPickingImageEnv": "gym4real.robofeeder.env",
    "RoboFeederPlanningEnv": "gym4real.robofeeder.planning",
    "RoboFeederConfig": "gym4real.robofeeder.config",
    "PickingConfig": "gym4real.robofeeder.config",
    "PlanningConfig": "gym4real.robofeeder.config",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module `gym4real.robofeeder` has no attribute `{name}`")


__all__ = [
    "PickingConfig",
    "PlanningConfig",
    "RoboFeederConfig",
    "RoboFeederPickingEnv",
    "RoboFeederPickingImageEnv",
    "RoboFeederPlanningEnv",
]
