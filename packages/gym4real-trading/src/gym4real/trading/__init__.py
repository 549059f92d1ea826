"""TradingEnv of Gym4ReaL. Re-exports are lazy: the plugin module imports this package at discovery."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gym4real.trading.config import TradingConfig
    from gym4real.trading.env import TradingEnv

_LAZY = {"TradingEnv": "gym4real.trading.env", "TradingConfig": "gym4real.trading.config"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module `gym4real.trading` has no attribute `{name}`")


__all__ = ["TradingConfig", "TradingEnv"]
