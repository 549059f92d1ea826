"""Executors of a reproduce plan: every training run of it, finished or reused.

A run whose folder already holds a finished run of the same settings is reused; an unfinished one resumes
from its last checkpoint (:func:`gym4real.rl.train.train`). A run that fails is reported with its
error and does not stop the others.

:func:`train_plan` runs the plan here, one run at a time, or ``jobs`` runs at a time: here and in
``jobs - 1`` worker processes that take the runs in turn (started with ``spawn`` while this process already
trains, their numerical libraries, and this process's while it trains beside them, limited to one thread
each, so that ``jobs`` runs on ``jobs`` cores do not oversubscribe them). A worker that dies
(killed, out of memory) loses the work since its run's last checkpoint: the run starts again from that
checkpoint in a new worker, up to :data:`MAX_RETRIES` times. Every run is seeded and independent of the
others, so the results do not depend on ``jobs`` or on the order the runs finish in.
:mod:`gym4real.results.cluster` runs a plan on Ray.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import signal
import sys
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from gym4real.core.errors import Gym4RealError
from gym4real.core.registry import slug
from gym4real.results.plan import Item
from gym4real.rl.progress import PlanProgress, Progress
from gym4real.results.run_files import check_run_folder
from gym4real.rl.train import TrainingRun, finished_run, label, train

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
    """``dam-v0 ppo seed 3`` (``ppo-jax`` for the JAX trainer)."""
    return f"{slug(item.env_id)} {label(item.algo, item.trainer)} seed {item.seed}"


def run_item(item: Item, progress: Progress | None = None, eval_beside: bool | None = None) -> TrainingRun:
    """Train one run of a plan, or reuse the finished run in its folder.

    ``eval_beside`` is :func:`~gym4real.rl.train.train`'s: False where the plan's runs book every core.

    Raises:
        DamagedRunError: A file of the run's folder cannot be read (unless ``item.retrain_damaged``).
    """
    check_run_folder(item.folder, describe_item(item), item.retrain_damaged)
    run = finished_run(item.folder, item.env_id, item.algo, item.preset, item.seed, item.trainer)
    if run is not None:
        return run
    return train(
        item.env_id, item.algo, item.preset, item.seed, item.folder, progress or False, item.trainer, eval_beside
    )


def train_plan(items: Sequence[Item], progress: PlanProgress | None = None, jobs: int = 1) -> list[Outcome]:
    """Run every item of a plan on this machine; one :class:`Outcome` per item, in the plan's order.

    Args:
        items: The plan.
        progress: The plan's progress bar; each item's progress is reported under its index.
        jobs: Runs at a time: 1 runs them here, in order; more run here and in ``jobs - 1`` worker processes
            (:class:`_Executor`).
    """
    if jobs < 1:
        raise Gym4RealError(f"--jobs must be at least 1 (or `auto`), not {jobs}")
    if jobs > 1 and len(items) > 1:
        return _Executor(items, progress, jobs).run()
    outcomes = []
    for key, item in enumerate(items):
        outcomes.append(_run_here(key, item, progress))
    return outcomes


def _run_here(key: int, item: Item, progress: PlanProgress | None, poll: Callable[[], None] | None = None) -> Outcome:
    """Run item ``key`` in this process (``poll`` is called as it reports progress); its bar item is closed.

    Beside workers (``poll`` given) the JAX trainer evaluates in-line: the plan's runs book every core.
    """

    def report(done: int, total: int) -> None:
        if progress is not None:
            progress.item(item.env_id, done, total, key)
        if poll is not None:
            poll()

    try:
        outcome = Outcome(item, run_item(item, report, False if poll is not None else None))
    except Exception as exc:  # one run's failure (missing data, a bug) must not stop the others
        outcome = Outcome(item, None, describe_error(exc))
    if progress is not None:
        progress.close_item(key)
    return outcome


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
    """A worker process: says it is ready, then runs of the plan, one at a time, until told to stop."""
    messages.put(("ready", os.getpid()))
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
            messages.put(("done", key, Outcome(item, run_item(item, report, eval_beside=False))))
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
    """A worker process, whether it has started (``ready``), and the run it is on (``key``, None when idle)."""

    def __init__(self, context: Any, messages: Any) -> None:
        self.tasks = context.SimpleQueue()
        self.process = context.Process(target=_serve, args=(self.tasks, messages), daemon=True)
        with thread_limits():
            self.process.start()
        self.ready = False
        self.key: int | None = None

    def give(self, key: int, item: Item) -> None:
        self.key = key
        self.tasks.put((key, item))


class _Executor:
    """``jobs`` runs at a time: this process and ``jobs - 1`` worker processes take the runs in turn.

    A worker process takes seconds to start (it imports torch and the domains, and compiles their numba
    code), which a plan of short runs would spend waiting: this process runs the plan's runs from its end
    while the workers start, and each worker, once started, takes them from its beginning, so a plan of
    seconds costs no more than one job and a long one gains a worker per job. This process checks on the
    workers whenever its own run reports progress (every step of it) and between runs. A run whose worker
    died starts again, from its last checkpoint, in a new worker (or here).
    """

    def __init__(self, items: Sequence[Item], progress: PlanProgress | None, jobs: int) -> None:
        self.items, self.progress = items, progress
        self.context = multiprocessing.get_context("spawn")
        self.messages = self.context.Queue()
        self.waiting = deque(range(len(items)))
        self.tries = dict.fromkeys(range(len(items)), 0)
        self.outcomes: dict[int, Outcome] = {}
        self.workers = [_Worker(self.context, self.messages) for _ in range(min(jobs, len(items)) - 1)]
        self.polled = 0.0

    def run(self) -> list[Outcome]:
        """Run the plan; its outcomes in the plan's order."""
        saved = _limit_torch_threads()
        try:
            while len(self.outcomes) < len(self.items):
                self.service(wait=False)
                if self.waiting:  # this process takes the last run waiting
                    key = self.waiting.pop()
                    self.tries[key] += 1
                    with thread_limits():
                        self.outcomes[key] = _run_here(key, self.items[key], self.progress, self.poll)
                else:
                    self.service(wait=True)
            self.stop()
        finally:
            _limit_torch_threads(saved)
            for worker in self.workers:
                if worker.process.is_alive():
                    worker.process.kill()
                    worker.process.join()
            self.messages.close()
        return [self.outcomes[key] for key in range(len(self.items))]

    def poll(self) -> None:
        """Check on the workers while this process runs, at most every :data:`REPORT_EVERY_S`."""
        now = time.monotonic()
        if now - self.polled >= REPORT_EVERY_S:
            self.polled = now
            self.service(wait=False)

    def service(self, wait: bool) -> None:
        """Read the workers' messages (waiting a little for one when ``wait``), replace the dead, give out runs."""
        self.give_out()
        dead = [w for w in self.workers if not w.process.is_alive()]
        self.read(wait=wait and not dead)  # the dead's last messages too
        for worker in dead:
            self.workers.remove(worker)
            worker.process.join()
            if worker.key is not None:
                self.retry(worker.key, _death(worker.process.exitcode))
            if self.waiting and worker.ready:  # one that never started would not start again
                self.workers.append(_Worker(self.context, self.messages))
        self.give_out()

    def give_out(self) -> None:
        """The first runs waiting to the started, idle workers."""
        for worker in self.workers:
            if worker.ready and worker.key is None and self.waiting:
                key = self.waiting.popleft()
                self.tries[key] += 1
                worker.give(key, self.items[key])

    def retry(self, key: int, death: str) -> None:
        """Run ``key``'s worker died: the run waits again (first in line), or fails after :data:`MAX_RETRIES`."""
        if self.tries[key] <= MAX_RETRIES:
            self.waiting.appendleft(key)
            if self.progress is not None:
                self.progress.retry(key, f"{describe_item(self.items[key])}: worker {death}; resuming the run")
        else:
            self.outcomes[key] = Outcome(
                self.items[key], None, f"its worker died {self.tries[key]} times, last {death}"
            )
            if self.progress is not None:
                self.progress.close_item(key)

    def read(self, wait: bool) -> None:
        """Every message the workers sent (waiting a little for the first when ``wait``)."""
        timeout = 0.2 if wait else 0.0
        while True:
            try:
                kind, key, *body = self.messages.get(timeout=timeout) if timeout else self.messages.get_nowait()
            except queue.Empty:
                return
            timeout = 0.0
            if kind == "ready":  # ``key`` is the worker's process id
                for worker in self.workers:
                    worker.ready |= worker.process.pid == key
            elif kind == "done":
                self.outcomes[key] = body[0]
                for worker in self.workers:
                    if worker.key == key:
                        worker.key = None
                if self.progress is not None:
                    self.progress.close_item(key)
            elif self.progress is not None:
                done, total = body
                self.progress.item(self.items[key].env_id, done, total, key)

    def stop(self) -> None:
        """Tell the started workers to stop (those still starting are killed: they hold nothing)."""
        for worker in self.workers:
            if worker.ready:
                worker.tasks.put(None)
            else:
                worker.process.kill()
        for worker in self.workers:
            worker.process.join(timeout=10)


def _limit_torch_threads(threads: int | None = 1) -> int | None:
    """Set torch's intra-op threads of this process (if torch is loaded) to ``threads``; return the former.

    This process runs its share of a parallel plan limited to one thread, as the workers are
    (:data:`THREAD_LIMITS`), so that ``jobs`` runs on ``jobs`` cores do not oversubscribe them. None: no change.
    """
    torch = sys.modules.get("torch")
    if torch is None or threads is None:
        return None
    former = int(torch.get_num_threads())
    torch.set_num_threads(threads)
    return former
