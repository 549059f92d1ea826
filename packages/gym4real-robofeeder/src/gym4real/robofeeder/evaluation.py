"""Evaluation protocols of the RoboFeeder environments (the reference has none: seeded episodes)."""

from __future__ import annotations

from typing import Any

#: First seed of the evaluation episodes (training runs use other seeds).
TEST_SEED = 1000
PICKING_EPISODES = 100
PLANNING_EPISODES = 50


def test_episodes(env_kwargs: dict[str, Any]) -> list[dict[str, Any]]:
    """The picking environments' seeded evaluation episodes (100)."""
    return [{"seed": TEST_SEED + i, "options": None} for i in range(PICKING_EPISODES)]


def planning_test_episodes(env_kwargs: dict[str, Any]) -> list[dict[str, Any]]:
    """The planning environment's seeded evaluation episodes (50)."""
    return [{"seed": TEST_SEED + i, "options": None} for i in range(PLANNING_EPISODES)]
