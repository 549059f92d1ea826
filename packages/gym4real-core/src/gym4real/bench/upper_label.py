"""The name an upper reference goes by in figures and tables: its mark and its kind of bound.

Apart from :mod:`gym4real.bench.upper_reference` (which plans and measures upper references) so that the
figures name them without importing the planners' machinery.
"""

from __future__ import annotations

from gym4real.core.registry import MARK, non_causal, upper_reference


def label(env_id: str, name: str) -> str:
    """A policy's name in figures: an upper reference's with its mark and kind.

    For example ``hindsight (non-causal upper reference, exact)``.
    """
    if name not in non_causal(env_id):
        return name
    spec = upper_reference(env_id, name)
    kind = (
        f"heuristic, gap {100 * spec.gap:.2g} %" if spec.bound == "heuristic" and spec.gap is not None else spec.bound
    )
    return f"{name} ({MARK}, {kind})"
