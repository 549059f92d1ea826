"""The passive baselines of the paper: Buy&Hold, Sell&Hold, and always flat."""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from gym4real.core.policies import ConstantPolicy
from gym4real.trading.env import FLAT, LONG, SHORT


def buy_and_hold(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: long all day (closed by the env at the end of the day)."""
    return ConstantPolicy(LONG)


def sell_and_hold(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: short all day."""
    return ConstantPolicy(SHORT)


def flat(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: never in the market (zero P&L, zero fees)."""
    return ConstantPolicy(FLAT)
