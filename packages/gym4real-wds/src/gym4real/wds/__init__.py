"""WDSEnv of Gym4ReaL. Re-exports are lazy: the plugin module imports this package at discovery."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gym4real.wds.config import WDSConfig
    from gym4real.wds.env import WDSEnv

_LAZY = {"WDSEnv": "gym4real.wds.env", "WDSConfig": "gym4real.wds.config"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module `gym4real.wds` has no attribute `{name}`")


__all__ = ["WDSConfig", "WDSEnv"]
