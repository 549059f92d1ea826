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


def test_placements(env_kwargs: dict[str, Any]) -> list[tuple[float, float]]:
    """Where picking-v0's object lies in each test episode: ``(u, v)`` pixels of its centre in the camera image.

    Read by resetting the env with each episode's seed (:func:`test_episodes`), as the protocol does: the
    positions the policies were tested on.
    """
    import gymnasium as gym

    import gym4real  # noqa: F401  (registers the ids)
    from gym4real.robofeeder._plugin import PICKING_V0

    env = gym.make(PICKING_V0, **env_kwargs)
    try:
        sim = env.unwrapped.sim  # type: ignore[attr-defined]
        found = []
        for episode in test_episodes(env_kwargs):
            env.reset(seed=episode["seed"], options=episode["options"])
            u, v = sim.camera.world_to_pixel(sim.object_centres()[0])
            found.append((float(u), float(v)))
    finally:
        env.close()
    return found


def planning_test_episodes(env_kwargs: dict[str, Any]) -> list[dict[str, Any]]:
    """The planning environment's seeded evaluation episodes (50)."""
    return [{"seed": TEST_SEED + i, "options": None} for i in range(PLANNING_EPISODES)]
