"""MicrogridEnv of Gym4ReaL and its battery digital twin. Re-exports are lazy: the plugin imports this package."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gym4real.microgrid.battery import BatteryParams, BatteryTwin, TwinOptions, load_battery
    from gym4real.microgrid.config import MicrogridConfig
    from gym4real.microgrid.env import MicrogridEnv

_LAZY = {
    "MicrogridEnv": "gym4real.microgrid.env",
    "MicrogridConfig": "gym4real.microgrid.config",
    "BatteryTwin": "gym4real.microgrid.battery",
    "BatteryParams": "gym4real.microgrid.battery",
    "TwinOptions": "gym4real.microgrid.battery",
    "load_battery": "gym4real.microgrid.battery",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module `gym4real.microgrid` has no attribute `{name}`")


__all__ = ["BatteryParams", "BatteryTwin", "MicrogridConfig", "MicrogridEnv", "TwinOptions", "load_battery"]
