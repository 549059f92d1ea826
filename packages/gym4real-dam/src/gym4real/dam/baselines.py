"""Rule-based policies of the reference benchmark notebook, and the historical operators.

Every factory takes the environment (``gymnasium.make`` output or raw env) and returns a callable
``obs -> action``. ``random`` is core's :func:`~gym4real.core.policies.random_policy`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from gym4real.core.policies import ConstantPolicy
from gym4real.dam.env import DamEnv
from gym4real.dam.historical import Historical


def mean(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: the middle of the action box, ``(low + high) / 2`` (245.805 m3/s by default)."""
    space: spaces.Box = env.action_space  # type: ignore[assignment]
    return ConstantPolicy(((space.low + space.high) / 2).astype(space.dtype))


def max_release(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: the top of the action box (491.61 m3/s by default)."""
    space: spaces.Box = env.action_space  # type: ignore[assignment]
    return ConstantPolicy(space.high.copy())


class ExponentialAverageDemand:
    """Release the exponential average of past demand (the ``ead`` baseline).

    The value is the env's float64 average, as the reference notebook reads it from the previous step's
    ``info``: 0 at the first step of an episode (the lake then releases the minimum flow), and from then on
    the average including the previous day's demand. The action stays float64, wider than the box's
    float32, as in the reference (rounding it to float32 moved the reference's returns by up to 4e-4).
    """

    def __init__(self, env: gym.Env[Any, Any], scale: float = 1.0) -> None:
        self.env: DamEnv = env.unwrapped  # type: ignore[assignment]
        self.scale = scale

    def __call__(self, obs: Any) -> np.ndarray:
        """Return the average demand (times ``scale``) as the release."""
        return np.array([self.scale * self.env.exponential_average_demand], dtype=np.float64)


def ead(env: gym.Env[Any, Any]) -> ExponentialAverageDemand:
    """Baseline factory: release the exponential average of past demand."""
    return ExponentialAverageDemand(env)


def scaled_ead(env: gym.Env[Any, Any], scale: float) -> ExponentialAverageDemand:
    """Policy factory: release ``scale`` times the exponential average of past demand (``ead`` is ``scale=1``).

    Below 1 the lake keeps water back (fewer floods averted, more deficit), above 1 it releases ahead of demand.
    """
    if not np.isfinite(scale) or scale < 0:
        raise ValueError(f"scaled_ead: `scale` must be a finite number >= 0, not {scale}")
    return ExponentialAverageDemand(env, float(scale))


def constant_release(env: gym.Env[Any, Any], fraction: float) -> ConstantPolicy:
    """Policy factory: release ``low + fraction (high - low)`` every day (``mean`` is 0.5, ``max`` is 1)."""
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"constant_release: `fraction` must be in [0, 1], not {fraction}")
    space: spaces.Box = env.action_space  # type: ignore[assignment]
    return ConstantPolicy((space.low + fraction * (space.high - space.low)).astype(space.dtype))


def historical(env: gym.Env[Any, Any]) -> Historical:
    """Baseline factory: the historical operators, tracking the recorded level (mass balance inverted)."""
    return Historical(env, mode="track")


def historical_replay(env: gym.Env[Any, Any]) -> Historical:
    """Baseline factory: replay of the historical releases reconstructed from the recorded levels."""
    return Historical(env, mode="replay")
