"""Evaluation protocols of the RoboFeeder environments (the reference has none: seeded episodes)."""

from __future__ import annotations

from typing import Any

#: First seed of the evaluation episodes (training runs use other seeds).
TEST_SEED = 1000
PICKING_EPISODES = 100
PLANNING_EPISODES = 50


def test_episodes(env_kwargs: dict[str, Any]) -> list[dict[str, Any]]:
    """Seeded evaluation episodes: 100 for picking (``preset="test"``), 50 for planning (``planning_test``)."""
    planning = str(env_kwargs.get("preset", "")).startswith("planning")
    n = PLANNING_EPISODES if planning else PICKING_EPISODES
    return [{"seed": TEST_SEED + i, "options": None} for i in range(n)]
