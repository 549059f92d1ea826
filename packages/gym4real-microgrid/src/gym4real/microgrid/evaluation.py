"""The paper's evaluation protocol of MicrogridEnv: one 2019 episode per test household 370..397."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

TEST_PROFILES = tuple(str(p) for p in range(370, 398))


def test_episodes(env_kwargs: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The 28 evaluation episodes, in the reference's order, each with its profile as a reset option.

    Profiles can be narrowed with ``env_kwargs["profiles"]``; seeds ``0..27`` drive any randomness left
    (``random_battery_init``), the profile itself is fixed by the option.
    """
    profiles = env_kwargs.get("profiles") or TEST_PROFILES
    return [{"seed": i, "options": {"profile": str(p)}} for i, p in enumerate(profiles)]
