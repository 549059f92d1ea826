"""The paper's evaluation protocol of DamEnv: the 13 test years, one one-year episode each."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

#: The test years in the order of the test files (the reference's evaluation order).
TEST_YEARS = (1950, 1970, 1996, 1961, 1994, 1971, 1966, 2009, 2010, 1952, 2007, 1998, 1974)


def test_episodes(env_kwargs: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The 13 evaluation episodes: test year ``TEST_YEARS[i]`` with seed ``i`` (seeds only drive ``random``).

    Each episode names its year (``options={"year": ...}``), so the protocol does not depend on the
    position of the env's year cycle; upstream mode gives the same years in the same order.
    """
    years = env_kwargs.get("years") or TEST_YEARS
    return [{"seed": i, "options": {"year": int(year)}} for i, year in enumerate(years)]
