"""A reproduce plan on Ray (extra ``cluster``): the cluster that ``RAY_ADDRESS`` names, else a local instance.

Each run of the plan is one Ray task (Ray core, not Tune: a task per run gives the resources of a run, the
retries of a lost worker and the results through the storage in a few lines, and our trainers already
checkpoint and resume). A task asks for one CPU; a task whose worker or node dies is retried by Ray up to
:data:`~gym4real.results.runner.MAX_RETRIES` times, on any node. Workers share no filesystem with the
driver: a task restores its run folder from the storage (:class:`~gym4real.rl.storage.Storage`), trains
in a scratch folder, uploads the folder after each checkpoint and at the end, and the driver downloads every
run folder into the output folder, where the results page is built from them.
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from gym4real.core.errors import Gym4RealError
from gym4real.results.plan import Item
from gym4real.rl.progress import PlanProgress
from gym4real.results.runner import MAX_RETRIES, THREAD_LIMITS, Outcome, describe_error, describe_item, run_item
from gym4real.rl.storage import MARKERS, Storage
from gym4real.rl.train import finished_run


def _ray() -> Any:
    try:
        import ray
    except ImportError as exc:
        raise Gym4RealError(
            f'--ray needs the `cluster` extra ({exc.name} is missing): `pip install "gym4real-core[cluster]"`'
        ) from exc
    return ray


def train_task(item: Item, relative: str, storage_uri: str) -> str | None:
    """One run of the plan on a Ray worker; its folder goes to the storage. Returns its error, if any."""
    storage = Storage(storage_uri)
    with tempfile.TemporaryDirectory(prefix="gym4real-run-") as scratch:
        folder = Path(scratch) / "run"
        storage.download(relative, folder)
        if finished_run(folder, item.env_id, item.algo, item.preset, item.seed, item.trainer) is not None:
            return None
        markers = [folder / name for name in MARKERS]
        synced: list[int] = []

        def sync_checkpoints(done: int, total: int) -> None:
            stamps = [m.stat().st_mtime_ns for m in markers if m.exists()]
            if stamps and stamps != synced:
                storage.upload(folder, relative)
                synced[:] = stamps

        error = None
        try:
            run_item(dataclasses.replace(item, folder=folder), sync_checkpoints, eval_beside=False)  # one CPU a task
        except Exception as exc:  # reported to the driver, which goes on with the other runs
            error = describe_error(exc)
        storage.upload(folder, relative)
    return error


def train_on_ray(
    items: Sequence[Item], out: Path, storage: str | Path | None = None, progress: PlanProgress | None = None
) -> list[Outcome]:
    """Run every item of a plan as a Ray task; one :class:`~gym4real.results.runner.Outcome` per item.

    Args:
        items: The plan; each item's folder lies in ``out``.
        out: The output folder: the run folders are downloaded into it.
        storage: Where the workers keep the run folders (default ``out``, which then must be a folder every
            node reaches, e.g. on NFS, or a single machine).
        progress: The plan's progress bar, advanced as runs finish.
    """
    ray = _ray()
    out = Path(out).resolve()
    store = Storage(storage if storage is not None else out)
    started = not ray.is_initialized()
    if started:  # RAY_ADDRESS names a cluster; without it, ray.init starts a local instance
        ray.init(runtime_env={"env_vars": THREAD_LIMITS}, log_to_driver=False)
    task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(train_task)
    outcomes: dict[int, Outcome] = {}
    pending: dict[Any, int] = {}
    try:
        for key, item in enumerate(items):
            run = finished_run(item.folder, item.env_id, item.algo, item.preset, item.seed, item.trainer)
            if run is not None:
                outcomes[key] = Outcome(item, run)
                if progress is not None:
                    progress.close_item(key)
                continue
            relative = item.folder.resolve().relative_to(out).as_posix()
            pending[task.remote(item, relative, store.uri)] = key
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            key = pending.pop(done[0])
            item = items[key]
            try:
                error = ray.get(done[0])
            except ray.exceptions.RayError as exc:  # its worker or node died more often than Ray retries
                error = f"{describe_item(item)}: {describe_error(exc)}"
            outcomes[key] = _collect(item, store, out, error)
            if progress is not None:
                progress.close_item(key)
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
        if started:
            ray.shutdown()
    return [outcomes[key] for key in range(len(items))]


def _collect(item: Item, store: Storage, out: Path, error: str | None) -> Outcome:
    """The run of ``item`` from the storage, downloaded into its folder in ``out``."""
    relative = item.folder.resolve().relative_to(out).as_posix()
    if store.local_path(relative) != item.folder.resolve():
        store.download(relative, item.folder)
    run = finished_run(item.folder, item.env_id, item.algo, item.preset, item.seed, item.trainer)
    if run is None:
        return Outcome(item, None, error or f"{describe_item(item)}: the storage holds no finished run")
    return Outcome(item, run)
