"""Executors of a reproduce plan: every training run of it, finished or reused.

A run whose folder already holds a finished run of the same settings is reused; an unfinished one resumes
from its last checkpoint (:func:`gym4real.core.rl.train.train`). A run that fails is reported with its
error and does not stop the others.

:func:`train_plan` runs the plan here, one run at a time, or ``jobs`` runs at a time in ``jobs`` worker
processes that take the runs in turn (started with ``spawn``, their numerical libraries limited to one
thread each, so that ``jobs`` workers on ``jobs`` cores do not oversubscribe them). A worker that dies
(killed, out of memory) loses the work since its run's last checkpoint: the run starts again from that
checkpoint in a new worker, up to :data:`MAX_RETRIES` times. Every run is seeded and independent of the
others, so the results do not depend on ``jobs`` or on the order the runs finish in.
:mod:`gym4real.core.rl.cluster` runs a plan on Ray.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import signal
import time
from collections import deque
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from gym4real.core.errors import Gym4RealError
from gym4real.core.rl.plan import Item, slug
from gym4real.core.rl.progress import PlanProgress, Progress
from gym4real.core.rl.run_files import check_run_folder
from gym4real.core.rl.train import TrainingRun, finished_run, train

#: Environment variables that limit a worker's numerical libraries to one thread; a worker process
#: gets them at its start, before it imports numpy, torch or numba.
THREAD_LIMITS = {
    name: "1"
    for name in (
        "OMP_NUM_THREADS",
        "MKL_NUM_THREADS",
        "OPENBLAS_NUM_THREADS",
        "NUMEXPR_NUM_THREADS",
        "VECLIB_MAXIMUM_THREADS",
        "NUMBA_NUM_THREADS",
    )
}
#: How many times a run whose worker died starts again from its last checkpoint.
MAX_RETRIES = 2
#: A worker reports its run's progress at most this often (seconds).
REPORT_EVERY_S = 0.5


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


def describe_item(item: Item) -> str:
    """``dam-v0 ppo seed 3``."""
    return f"{slug(item.env_id)} {item.algo} seed {item.seed}"


def available_cpus() -> int:
    """The cores this process may run on (``--jobs auto``)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def run_item(item: Item, progress: Progress | None = None) -> TrainingRun:
    """Train one run of a plan, or reuse the finished run in its folder.

    Raises:
        DamagedRunError: A file of the run's folder cannot be read (unless ``item.retrain_damaged``).
    """
    check_run_folder(item.folder, describe_item(item), item.retrain_damaged)
    run = finished_run(item.folder, item.env_id, item.algo, item.preset, item.seed)
    if run is not None:
        return run
    return train(item.env_id, item.algo, item.preset, item.seed, item.folder, progress or False)


def train_plan(items: Sequence[Item], progress: PlanProgress | None = None, jobs: int = 1) -> list[Outcome]:
    """Run every item of a plan on this machine; one :class:`Outcome` per item, in the plan's order.

    Args:
        items: The plan.
        progress: The plan's progress bar; each item's progress is reported under its index.
        jobs: Runs at a time: 1 runs them here, in order; more run each in a worker process.
    """
    if jobs < 1:
        raise Gym4RealError(f"--jobs must be at least 1 (or `auto`), not {jobs}")
    if jobs > 1 and len(items) > 1:
        return _train_in_workers(items, progress, jobs)
    outcomes = []
    for key, item in enumerate(items):

        def report(done: int, total: int, key: int = key, env_id: str = item.env_id) -> None:
            if progress is not None:
                progress.item(env_id, done, total, key)

        try:
            outcomes.append(Outcome(item, run_item(item, report)))
        except Exception as exc:  # one run's failure (missing data, a bug) must not stop the others
            outcomes.append(Outcome(item, None, describe_error(exc)))
        if progress is not None:
            progress.close_item(key)
    return outcomes


@contextmanager
def thread_limits() -> Iterator[None]:
    """:data:`THREAD_LIMITS` in ``os.environ`` while worker processes start (they inherit it)."""
    saved = {name: os.environ.get(name) for name in THREAD_LIMITS}
    os.environ.update(THREAD_LIMITS)
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _serve(tasks: Any, messages: Any) -> None:
    """A worker process: runs of the plan, one at a time, until told to stop; messages go to the parent."""
    while (task := tasks.get()) is not None:
        key, item = task
        last = 0.0

        def report(done: int, total: int, key: int = key) -> None:
            nonlocal last
            now = time.monotonic()
            if now - last >= REPORT_EVERY_S or done >= total:
                last = now
                messages.put(("progress", key, done, total))

        try:
            messages.put(("done", key, Outcome(item, run_item(item, report))))
        except Exception as exc:  # reported to the parent, which goes on with the other runs
            messages.put(("done", key, Outcome(item, None, describe_error(exc))))


def _death(exitcode: int | None) -> str:
    if exitcode is not None and exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exit status {exitcode}"


class _Worker:
    """A worker process and the run it is on (``key``, None when idle)."""

    def __init__(self, context: Any, messages: Any) -> None:
        self.tasks = context.SimpleQueue()
        self.process = context.Process(target=_serve, args=(self.tasks, messages), daemon=True)
        with thread_limits():
            self.process.start()
        self.key: int | None = None

    def give(self, key: int, item: Item) -> None:
        self.key = key
        self.tasks.put((key, item))


def _train_in_workers(items: Sequence[Item], progress: PlanProgress | None, jobs: int) -> list[Outcome]:
    """``jobs`` worker processes take the runs in turn; a run whose worker died starts again in a new one."""
    context = multiprocessing.get_context("spawn")
    messages = context.Queue()
    waiting = deque(range(len(items)))
    tries = dict.fromkeys(range(len(items)), 0)
    outcomes: dict[int, Outcome] = {}
    workers = [_Worker(context, messages) for _ in range(min(jobs, len(items)))]
    try:
        while len(outcomes) < len(items):
            for worker in workers:
                if worker.key is None and waiting:
                    key = waiting.popleft()
                    tries[key] += 1
                    worker.give(key, items[key])
            dead = [w for w in workers if not w.process.is_alive()]
            for key, outcome in _read(messages, items, progress, wait=not dead):  # the dead's last ones too
                outcomes[key] = outcome
                next(w for w in workers if w.key == key).key = None
            for worker in dead:
                workers.remove(worker)
                worker.process.join()
                if worker.key is not None:
                    key = worker.key
                    death = _death(worker.process.exitcode)
                    if tries[key] <= MAX_RETRIES:
                        waiting.appendleft(key)
                        if progress is not None:
                            progress.retry(key, f"{describe_item(items[key])}: worker {death}; resuming the run")
                    else:
                        outcomes[key] = Outcome(items[key], None, f"its worker died {tries[key]} times, last {death}")
                        if progress is not None:
                            progress.close_item(key)
                if waiting:
                    workers.append(_Worker(context, messages))
        for worker in workers:
            worker.tasks.put(None)
        for worker in workers:
            worker.process.join(timeout=10)
    finally:
        for worker in workers:
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join()
        messages.close()
    return [outcomes[key] for key in range(len(items))]


def _read(messages: Any, items: Sequence[Item], progress: PlanProgress | None, wait: bool) -> list[tuple[int, Outcome]]:
    """Every message the workers sent (waiting a little for the first when ``wait``): the runs finished."""
    finished: list[tuple[int, Outcome]] = []
    timeout = 0.2 if wait else 0.0
    while True:
        try:
            kind, key, *body = messages.get(timeout=timeout) if timeout else messages.get_nowait()
        except queue.Empty:
            return finished
        timeout = 0.0
        if kind == "done":
            finished.append((key, body[0]))
            if progress is not None:
                progress.close_item(key)
        elif progress is not None:
            done, total = body
            progress.item(items[key].env_id, done, total, key)
