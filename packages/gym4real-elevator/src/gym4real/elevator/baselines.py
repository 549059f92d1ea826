"""Rule-based dispatching policies of the paper's notebooks (the spec's working versions)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from gym4real.elevator.env import DOWN, OPEN, UP, ElevatorEnv


class QueueFirst:
    """Carry a full or partial cabin straight down; when empty, go to a queue chosen by length.

    Args:
        env: The elevator environment (its geometry is read once).
        longest: True for longest-first (ties to the highest floor), False for shortest-first among the
            non-empty queues (ties to the lowest floor).
    """

    def __init__(self, env: gym.Env[Any, Any], longest: bool) -> None:
        base: ElevatorEnv = env.unwrapped  # type: ignore[assignment]
        self.ppf = base._ppf
        self.goal = base._goal
        self.floors = base._served_floors
        self.longest = longest

    def _toward(self, position: int, target: int) -> int:
        target_pos = target * self.ppf
        if position == target_pos:
            return OPEN
        return UP if target_pos > position else DOWN

    def __call__(self, obs: dict[str, Any]) -> int:
        """Return the action for an observation."""
        position = int(obs["current_position"])
        if obs["n_passengers"] > 0:
            return self._toward(position, self.goal)
        queues = [(int(q), f) for q, f in zip(obs["floor_queues"], self.floors, strict=True) if q > 0]
        if not queues:
            return OPEN
        if self.longest:
            _, target = max(queues)
        else:
            _, target = min(queues)
        return self._toward(position, target)


def longest_first(env: gym.Env[Any, Any]) -> QueueFirst:
    """Baseline factory: the longest queue first."""
    return QueueFirst(env, longest=True)


def shortest_first(env: gym.Env[Any, Any]) -> QueueFirst:
    """Baseline factory: the shortest non-empty queue first."""
    return QueueFirst(env, longest=False)
