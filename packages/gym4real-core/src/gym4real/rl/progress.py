"""Progress reporting of training runs and of a reproduce plan."""

from __future__ import annotations

from collections.abc import Callable

from gym4real.bench.progress import ProgressDisplay

Progress = Callable[[int, int], None]
"""``progress(done, total)``: a trainer's progress in its unit (episodes or timesteps)."""


def _slug(env_id: str) -> str:
    return env_id.split("/", 1)[-1]


class PlanProgress:
    """One progress bar over a whole plan: its training runs and each environment's test, one unit each.

    Items running at the same time (parallel executors) are told apart by ``key``, their index in the plan.
    """

    def __init__(self, total: int, show: bool) -> None:
        self.closed = 0
        self.running: dict[int, float] = {}
        self.bar = None
        if show:
            self.bar = ProgressDisplay(
                "reproduce",
                total,
                "runs and tests",
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.2f}/{total} runs and tests [{elapsed}<{remaining}]",
            )

    def _show(self) -> None:
        if self.bar is not None:
            self.bar.update(self.closed + sum(self.running.values()))

    def item(self, env_id: str, done: int, total: int, key: int = -1) -> None:
        """Item ``key`` has ``done`` of its ``total`` units done (a trainer may overshoot its budget)."""
        self.running[key] = min(done / max(total, 1), 1.0)
        if self.bar is not None:
            self.bar.describe(f"reproduce {_slug(env_id)}")
        self._show()

    def retry(self, key: int, message: str) -> None:
        """Item ``key`` starts again (its worker died): its progress restarts from its checkpoint's."""
        self.running.pop(key, None)
        if self.bar is not None:
            self.bar.write(message)
        self._show()

    def close_item(self, key: int = -1) -> None:
        """Item ``key`` is finished."""
        self.running.pop(key, None)
        self.closed += 1
        self._show()

    def close(self) -> None:
        """Close the bar."""
        if self.bar is not None:
            self.bar.close()
