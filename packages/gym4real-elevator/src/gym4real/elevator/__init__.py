"""ElevatorEnv of Gym4ReaL. Re-exports are lazy: the plugin module imports this package at discovery."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gym4real.elevator.config import ElevatorConfig
    from gym4real.elevator.env import ElevatorEnv

_LAZY = {"ElevatorEnv": "gym4real.elevator.env", "ElevatorConfig": "gym4real.elevator.config"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module `gym4real.elevator` has no attribute `{name}`")


__all__ = ["ElevatorConfig", "ElevatorEnv"]
