"""The nearest names to a mistyped one: one rule for env ids, config fields and policy names."""

from __future__ import annotations

import difflib
from collections.abc import Iterable

#: How alike a name must be to be suggested (:func:`difflib.get_close_matches`' ratio).
CUTOFF = 0.5


def nearest(name: str, candidates: Iterable[str], n: int = 3, cutoff: float = CUTOFF) -> list[str]:
    """The candidates nearest to ``name``, best first (at most ``n``; none when nothing is alike)."""
    return difflib.get_close_matches(name, list(candidates), n=n, cutoff=cutoff)


def did_you_mean(name: str, candidates: Iterable[str], n: int = 3) -> str:
    """`` Did you mean `max`?`` (the :func:`nearest` candidates), or ``""`` when none is near."""
    near = nearest(name, candidates, n)
    return f" Did you mean {', '.join(f'`{c}`' for c in near)}?" if near else ""
