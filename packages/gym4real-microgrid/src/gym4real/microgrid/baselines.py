"""Rule-based policies of the paper: a constant fraction of the net power sent to the battery."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.policies import ConstantPolicy


def _constant(fraction: float) -> ConstantPolicy:
    return ConstantPolicy(np.array([fraction], dtype=np.float32))


def only_market(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: a = 0, every hour's net power is traded (the battery only ages with time)."""
    return _constant(0.0)


def battery_first(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: a = 1, the battery takes or gives what it can, the market the rest."""
    return _constant(1.0)


def fifty_fifty(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: a = 0.5, half of the net power to the battery."""
    return _constant(0.5)


def constant_fraction(env: gym.Env[Any, Any], fraction: float) -> ConstantPolicy:
    """Policy factory: the same fraction every hour (``only_market`` 0, ``fifty_fifty`` 0.5, ``battery_first`` 1)."""
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"constant_fraction: `fraction` must be in [0, 1], not {fraction}")
    return _constant(float(fraction))
