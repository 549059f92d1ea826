"""Safe-RL view (Safety-Gymnasium convention): ``step`` returns the cost as a separate signal."""

from __future__ import annotations

from typing import Any

import gymnasium as gym


class SafetyCost(gym.Wrapper[Any, Any, Any, Any], gym.utils.RecordConstructorArgs):
    """``step`` returns ``(obs, reward, cost, terminated, truncated, info)`` with ``cost = info["cost"]``.

    Every Gym4ReaL env reports the cost of its constraint violations in ``info["cost"]`` (dam overflow and
    starving, microgrid SoC-window violations, wds tank overflow, robofeeder unfeasible targets, 0 where
    the domain has none).
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)

    def step(self, action: Any) -> tuple[Any, float, float, bool, bool, dict[str, Any]]:  # type: ignore[override]
        """Step; the cost comes out as the third item."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        if "cost" not in info:
            raise KeyError(f"{self.env.unwrapped.__class__.__name__} reports no `info['cost']`")
        return obs, float(reward), float(info["cost"]), terminated, truncated, info
