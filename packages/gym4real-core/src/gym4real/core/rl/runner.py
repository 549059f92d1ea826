"""Executors of a reproduce plan: every training run of it, finished or reused.

A run whose folder already holds a finished run of the same settings is reused; an unfinished one resumes
from its last checkpoint (:func:`gym4real.core.rl.train.train`). A run that fails is reported with its
error and does not stop the others.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from gym4real.core.errors import Gym4RealError
from gym4real.core.rl.plan import Item
from gym4real.core.rl.progress import PlanProgress
from gym4real.core.rl.train import TrainingRun, finished_run, train


@dataclass(frozen=True)
class Outcome:
    """What became of one run of a plan: its finished run, or the error that stopped it."""

    item: Item
    run: TrainingRun | None
    error: str | None = None


def describe_error(exc: BaseException) -> str:
    """One line for a failed run or env: our errors as they are, others with their type."""
    name = "" if isinstance(exc, Gym4RealError) else f"{type(exc).__name__}: "
    return name + " ".join(str(exc).split())


def run_item(item: Item, progress: PlanProgress | None = None) -> TrainingRun:
    """Train one run of a plan, or reuse the finished run in its folder."""
    run = finished_run(item.folder, item.env_id, item.algo, item.preset, item.seed)
    if run is not None:
        return run

    def on_progress(done: int, total: int) -> None:
        if progress is not None:
            progress.item(item.env_id, done, total)

    return train(item.env_id, item.algo, item.preset, item.seed, item.folder, on_progress)


def train_plan(items: Sequence[Item], progress: PlanProgress | None = None) -> list[Outcome]:
    """Run every item of a plan here, one at a time, in order; one :class:`Outcome` per item."""
    outcomes = []
    for item in items:
        try:
            outcomes.append(Outcome(item, run_item(item, progress)))
        except Exception as exc:  # one run's failure (missing data, a bug) must not stop the others
            outcomes.append(Outcome(item, None, describe_error(exc)))
        if progress is not None:
            progress.close_item()
    return outcomes
