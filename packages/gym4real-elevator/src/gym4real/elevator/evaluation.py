"""The paper's evaluation protocol of ElevatorEnv: 30 episodes."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

EPISODES = 30
SEED = 1234


def test_episodes(env_kwargs: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The 30 evaluation episodes.

    Corrected mode: seeds 1234..1263. Upstream mode: 30 consecutive resets without a seed, which is the
    reference's evaluation (its randomness comes from ``floors.seed``, 1234 in the ``test`` preset).
    """
    if env_kwargs.get("fidelity") == "upstream":
        return [{"seed": None, "options": None} for _ in range(EPISODES)]
    return [{"seed": SEED + i, "options": None} for i in range(EPISODES)]
