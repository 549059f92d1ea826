"""DamEnv of Gym4ReaL. Re-exports are lazy: the plugin module imports this package at discovery."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gym4real.dam.config import DamConfig
    from gym4real.dam.env import DamEnv

_LAZY = {"DamEnv": "gym4real.dam.env", "DamConfig": "gym4real.dam.config"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module `gym4real.dam` has no attribute `{name}`")


__all__ = ["DamConfig", "DamEnv"]
