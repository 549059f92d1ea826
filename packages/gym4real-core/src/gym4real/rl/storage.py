"""Run folders kept in a storage that every machine of a cluster reaches.

The storage is a local or NFS path, or any filesystem URI that pyarrow opens (``s3://bucket/prefix``,
``gs://...``, ``hdfs://...``). A worker restores its run's folder from the storage before it starts (so a
run resumes from its last checkpoint on whichever machine runs it), and uploads it after each checkpoint
and at the end; the driver downloads every run folder and builds the results from them. Each file is
written whole (to a temporary name, then moved), and a run's markers last: its checkpoint state, then
``run.json``, so a copy interrupted midway leaves the previous checkpoint or finished run readable.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gym4real.core.errors import Gym4RealError

#: Files written after all others, in this order: a run's checkpoint state, then its record of a finished run.
MARKERS = ("checkpoint/state.json", "checkpoint.npz", "run.json")
_PARTIAL = ".partial"


def write_whole(path: Path, write: Callable[[Path], object]) -> None:
    """``write`` the file to a temporary name beside ``path``, then move it there at once.

    A process killed midway leaves the previous ``path`` whole (a checkpoint, a best model), never half a file.
    """
    tmp = path.with_name(f"{path.stem}.tmp{path.suffix}")
    write(tmp)
    tmp.replace(path)


def _pyarrow_fs() -> Any:
    try:
        from pyarrow import fs
    except ImportError as exc:
        raise Gym4RealError(
            f'--storage needs pyarrow ({exc.name} is missing): `pip install "gym4real-core[cluster]"`'
        ) from exc
    return fs


def _order(relative: str) -> tuple[int, str]:
    return (MARKERS.index(relative) if relative in MARKERS else -1, relative)


class Storage:
    """The storage of a plan's run folders: ``<root>/<folder relative to the output folder>``."""

    def __init__(self, uri: str | Path) -> None:
        fs = _pyarrow_fs()
        self.uri = str(uri)
        target = self.uri if "://" in self.uri else str(Path(self.uri).resolve())
        try:
            self.fs, self.root = fs.FileSystem.from_uri(target)
        except (ValueError, OSError) as exc:
            raise Gym4RealError(
                f"--storage `{uri}` is not a path or a filesystem URI pyarrow opens (s3://bucket/prefix, ...): {exc}"
            ) from exc
        self.root = self.root.rstrip("/")
        self._local = isinstance(self.fs, fs.LocalFileSystem)

    def local_path(self, relative: str) -> Path | None:
        """Where a run folder lies when the storage is a path of this machine, else None."""
        return Path(self.root) / relative if self._local else None

    def _entries(self, path: str) -> tuple[set[str], set[str]]:
        """The files and the folders under ``path``, relative to it (none when it does not exist)."""
        fs = _pyarrow_fs()
        if self.fs.get_file_info(path).type == fs.FileType.NotFound:
            return set(), set()
        files, folders = set(), set()
        for info in self.fs.get_file_info(fs.FileSelector(path, recursive=True)):
            name = info.path[len(path) + 1 :]
            if info.type == fs.FileType.Directory:
                folders.add(name)
            elif info.type == fs.FileType.File and not name.endswith(_PARTIAL):
                files.add(name)
        return files, folders

    def upload(self, folder: Path, relative: str) -> None:
        """Mirror a local run folder into the storage (files gone from ``folder`` are deleted there)."""
        remote = f"{self.root}/{relative}"
        local = {p.relative_to(folder).as_posix(): p for p in folder.rglob("*") if p.is_file()}
        self.fs.create_dir(remote, recursive=True)
        for name in sorted(local, key=_order):
            target = f"{remote}/{name}"
            self.fs.create_dir(target.rsplit("/", 1)[0], recursive=True)
            with local[name].open("rb") as src, self.fs.open_output_stream(target + _PARTIAL) as dst:
                shutil.copyfileobj(src, dst, 1 << 20)
            self.fs.move(target + _PARTIAL, target)
        files, folders = self._entries(remote)
        for name in sorted(files - set(local), key=_order, reverse=True):
            self.fs.delete_file(f"{remote}/{name}")
        gone: list[str] = []
        for name in sorted(folders - {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_dir()}):
            if not any(name.startswith(f"{parent}/") for parent in gone):  # deleting a folder deleted its children
                self.fs.delete_dir(f"{remote}/{name}")
                gone.append(name)

    def download(self, relative: str, folder: Path) -> bool:
        """Mirror the storage's copy of a run folder into ``folder``; False when the storage has none."""
        remote = f"{self.root}/{relative}"
        files, _ = self._entries(remote)
        if not files:
            return False
        folder.mkdir(parents=True, exist_ok=True)
        for name in sorted(files, key=_order):
            target = folder / name
            target.parent.mkdir(parents=True, exist_ok=True)
            partial = target.with_name(target.name + _PARTIAL)
            with self.fs.open_input_stream(f"{remote}/{name}") as src, partial.open("wb") as dst:
                shutil.copyfileobj(src, dst, 1 << 20)
            partial.replace(target)
        for path in sorted(folder.rglob("*"), reverse=True):  # children before their folder
            if path.relative_to(folder).as_posix() in files:
                continue
            if path.is_dir() and not any(path.iterdir()):
                path.rmdir()
            elif path.is_file():
                path.unlink()
        return True
