"""What the native batched envs share: the episode limit Gymnasium passes to a vector entry point."""

from __future__ import annotations

import operator


def check_max_episode_steps(value: object) -> int | None:
    """Validate ``max_episode_steps`` of a native vector env (``gymnasium.make_vec`` passes it through).

    A native vector env truncates every copy after this many steps, as ``gymnasium.make`` wraps a
    single env in ``TimeLimit``; ``None`` or ``-1`` (``make``'s "no wrapper") mean no limit.

    Raises:
        ValueError: Not a positive int, None or -1.
    """
    if value is None or (not isinstance(value, bool) and value == -1):
        return None
    try:
        steps = None if isinstance(value, bool) else operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        steps = None
    if steps is None or steps < 1:
        raise ValueError(f"max_episode_steps must be a positive int (or None for no limit), not {value!r}")
    return steps
