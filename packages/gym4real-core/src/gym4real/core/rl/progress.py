"""Progress reporting of training runs and of a reproduce plan."""

from __future__ import annotations

from collections.abc import Callable

Progress = Callable[[int, int], None]
"""``progress(done, total)``: a trainer's progress in its unit (episodes or timesteps)."""


def _slug(env_id: str) -> str:
    return env_id.split("/", 1)[-1]


class PlanProgress:
    """One progress bar over a whole plan: its training runs and each environment's test, one unit each."""

    def __init__(self, total: int, show: bool) -> None:
        self.closed = 0
        self.bar = None
        if show:
            from tqdm.auto import tqdm

            self.bar = tqdm(
                total=total,
                desc="reproduce",
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.2f}/{total} runs and tests [{elapsed}<{remaining}]",
            )

    def item(self, env_id: str, done: int, total: int) -> None:
        """The current item has ``done`` of its ``total`` units done (a trainer may overshoot its budget)."""
        if self.bar is not None:
            self.bar.set_description(f"reproduce {_slug(env_id)}", refresh=False)
            self.bar.update(self.closed + min(done / max(total, 1), 1.0) - self.bar.n)

    def close_item(self) -> None:
        """The current item is finished."""
        self.closed += 1
        if self.bar is not None:
            self.bar.update(self.closed - self.bar.n)

    def close(self) -> None:
        """Close the bar."""
        if self.bar is not None:
            self.bar.close()
