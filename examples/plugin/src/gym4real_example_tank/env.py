"""TankEnv: keep the level of a tank at its target while a random outflow drains it."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

CAPACITY = 10.0  # m
TARGET = 5.0  # m
MAX_OUTFLOW = 1.0  # m per step, drawn uniformly in [0, MAX_OUTFLOW]


class TankEnv(gym.Env[np.ndarray, np.ndarray]):
    """Keep the level of a tank at its target while a random outflow drains it.

    Observation: ``Box(0, 10, (1,))``, the level (m). Action: ``Box(0, 1, (1,))``, the inflow of the
    step (m). Dynamics: ``level' = clip(level + inflow - outflow, 0, 10)`` with the outflow uniform in
    [0, 1]. Reward: ``-|level' - 5|`` (``info["reward_components"]["deviation"]``). The episode never
    terminates; the registered time limit is 100 steps.
    """

    def __init__(self) -> None:
        self.observation_space = gym.spaces.Box(0.0, CAPACITY, shape=(1,), dtype=np.float32)
        self.action_space = gym.spaces.Box(0.0, 1.0, shape=(1,), dtype=np.float32)
        self.level = TARGET

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """Start at a uniform random level."""
        super().reset(seed=seed)
        self.level = float(self.np_random.uniform(0.0, CAPACITY))
        return self._obs(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        """Add the inflow, drain a random outflow, and pay the distance to the target."""
        if not self.action_space.contains(np.asarray(action, dtype=np.float32)):
            raise ValueError(f"action {action!r} is not in {self.action_space}")
        outflow = float(self.np_random.uniform(0.0, MAX_OUTFLOW))
        self.level = float(np.clip(self.level + float(action[0]) - outflow, 0.0, CAPACITY))
        reward = -abs(self.level - TARGET)
        return self._obs(), reward, False, False, {"outflow": outflow, "reward_components": {"deviation": reward}}

    def _obs(self) -> np.ndarray:
        return np.array([self.level], dtype=np.float32)


def refill(env: gym.Env[Any, Any]) -> Callable[[np.ndarray], np.ndarray]:
    """Baseline factory: an inflow that closes the gap to the target plus the mean outflow."""
    return lambda obs: np.clip([TARGET - obs[0] + MAX_OUTFLOW / 2], 0.0, 1.0).astype(np.float32)
