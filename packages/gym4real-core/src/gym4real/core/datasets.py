"""Resolution of data files: explicit folder, ``GYM4REAL_DATA_DIR``, user cache, then download.

Every file is checked against the SHA-256 its plugin registered. A download goes through pooch into a
staging folder of the user cache (``platformdirs``) and is moved into place only after its hash
matched; it must end within an overall deadline (``GYM4REAL_DOWNLOAD_DEADLINE`` seconds, default
300), since a per-read timeout never stops a server that trickles bytes. A failed, corrupt or late
download leaves no file and no folder behind; the staging folder of a killed one (its lock is gone) is
removed by the next download. ``GYM4REAL_OFFLINE=1`` forbids downloads.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import math
import os
import re
import shutil
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import platformdirs

from gym4real.core.errors import DataFileError, DataUnreachableError
from gym4real.core.registry import registry
from gym4real.core.specs import DatasetSpec

DATA_DIR_ENV = "GYM4REAL_DATA_DIR"
OFFLINE_ENV = "GYM4REAL_OFFLINE"
DEADLINE_ENV = "GYM4REAL_DOWNLOAD_DEADLINE"
#: Seconds a download may take in all, unless ``GYM4REAL_DOWNLOAD_DEADLINE`` says otherwise.
DEFAULT_DEADLINE = 300.0
#: Longest wait for one read (s); the deadline, when shorter, bounds it too.
READ_TIMEOUT = 60.0
#: Folder of the user cache where downloads are staged (one locked subfolder each).
STAGING = ".downloading"

_verified: dict[tuple[str, int, int, int, int], str] = {}


def cache_dir() -> Path:
    """Return the user cache folder of downloaded data (``GYM4REAL_CACHE_DIR`` overrides it)."""
    return Path(os.environ.get("GYM4REAL_CACHE_DIR") or platformdirs.user_cache_dir("gym4real"))


def sha256_of(path: Path) -> str:
    """Return the hex SHA-256 of a file, memoised on its path, size, modification and change times and inode.

    A file rewritten in place has a new change time (no user call sets it back), so it is hashed again.
    """
    st = path.stat()
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino)
    if key not in _verified:
        h = hashlib.sha256()
        with path.open("rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        _verified[key] = h.hexdigest()
    return _verified[key]


def standin_module(domain: str) -> Any:
    """``gym4real.<domain>.standin``, a domain's stand-in for data published nowhere we can reach, or None.

    Such a module has ``PATH`` (where the stand-in lies under a data folder), ``STANDS_IN_FOR`` (the
    registered file it replaces), ``DESCRIPTION`` (what it is, in a few words), ``HOUSEHOLDS`` (the default
    count), ``PUBLISHED`` (``households``, ``seed`` and ``sha256`` of the published stand-in),
    ``synthesize(...)`` (``gym4real data synthesize``), ``check_tools()`` (raises, naming what to install,
    before anything is written), ``expected_time(households, jobs)`` (text) and ``status()``.
    """
    import importlib

    try:
        return importlib.import_module(f"gym4real.{domain}.standin")
    except ModuleNotFoundError:
        return None


def stand_in_replacing(name: str) -> Any:
    """The stand-in module of ``name``'s domain (:func:`standin_module`) if it stands in for that file, else None."""
    module = standin_module(name.split("/", 1)[0])
    return module if module is not None and getattr(module, "STANDS_IN_FOR", None) == name else None


def dataset(name: str) -> DatasetSpec:
    """Return the registered spec of a dataset name."""
    datasets = registry().datasets
    if name not in datasets:
        raise DataFileError(f"unknown dataset `{name}`; registered: {sorted(datasets)}")
    return datasets[name]


@dataclass(frozen=True)
class Copy:
    """A copy of a data file: the place it was found in (``GYM4REAL_DATA_DIR``, ``user cache``...) and its path."""

    where: str
    path: Path


def places(data_dir: str | Path | None = None) -> list[tuple[str, Path]]:
    """The folders searched for data files, in order, each with the name of the setting that gave it."""
    found = []
    if data_dir:
        found.append(("config `data_dir`", Path(data_dir).expanduser()))
    if os.environ.get(DATA_DIR_ENV):
        found.append((DATA_DIR_ENV, Path(os.environ[DATA_DIR_ENV]).expanduser()))
    found.append(("user cache", cache_dir()))
    return found


def find(name: str, data_dir: str | Path | None = None) -> Copy | None:
    """Return the first copy of a registered data file in the places searched (unchecked), or None."""
    spec = dataset(name)
    for where, folder in places(data_dir):
        if (folder / spec.path).is_file():
            return Copy(where, folder / spec.path)
    return None


def find_stand_in(path: str, data_dir: str | Path | None = None) -> Copy | None:
    """Return the first copy of a stand-in in the places searched, or None.

    ``path`` is where it lies under a data folder (a :func:`standin_module`'s ``PATH``).
    """
    for where, folder in places(data_dir):
        if (folder / path).is_file():
            return Copy(where, folder / path)
    return None


def is_intact(spec: DatasetSpec, path: Path) -> bool:
    """Whether a file has the SHA-256 registered for it."""
    return sha256_of(path) == spec.sha256


def _check(spec: DatasetSpec, path: Path, where: str) -> None:
    if not is_intact(spec, path):
        raise DataFileError(
            f"data file `{spec.path}` ({spec.name}) in {where} `{path}` is corrupt: sha256 {sha256_of(path)}, "
            f"expected {spec.sha256}. Replace it with the upstream file {spec.url}"
        )


def upstream_folder(spec: DatasetSpec) -> str | None:
    """The upstream folder that is a data folder for this file, in words, or None if upstream lays it out otherwise.

    A file published on GitHub whose upstream path ends with its path here (``dam/MEF.csv`` under
    ``gym4real/data/`` of the reference repository) can be read from a copy of that folder through
    ``GYM4REAL_DATA_DIR``: ``the folder `gym4real/data` of github.com/Daveonwave/gym4ReaL at commit 774d5ce``.
    """
    url = urlsplit(spec.url)
    parts = url.path.strip("/").split("/")
    rel = "/".join(parts[3:])
    if url.hostname != "raw.githubusercontent.com" or len(parts) < 4 or not rel.endswith("/" + spec.path):
        return None
    ref = f"commit {parts[2][:7]}" if re.fullmatch(r"[0-9a-f]{40}", parts[2]) else parts[2]
    return f"the folder `{rel.removesuffix('/' + spec.path)}` of github.com/{parts[0]}/{parts[1]} at {ref}"


def where_to_get(spec: DatasetSpec) -> str:
    """Where a copy of the file comes from, for the fix of an error: its upstream data folder, else its address."""
    folder = upstream_folder(spec)
    return f"a copy of {folder} is one" if folder else f"upstream: {spec.url}"


def unreachable_host(exc: BaseException, url: str) -> str | None:
    """The host of ``url`` if ``exc`` is a failure to reach it (name resolution, connection), else None."""
    import requests

    return urlsplit(url).hostname if isinstance(exc, requests.ConnectionError) else None


def _cause(exc: BaseException) -> str:
    """The name of the innermost reason of a requests failure (``NameResolutionError``), else the exception's."""
    reason = getattr(exc.args[0], "reason", None) if exc.args else None
    return type(reason if isinstance(reason, BaseException) else exc).__name__


def download_deadline() -> float:
    """Seconds a download may take in all: ``GYM4REAL_DOWNLOAD_DEADLINE``, else :data:`DEFAULT_DEADLINE`.

    Raises:
        DataFileError: The variable is not a positive finite number.
    """
    raw = os.environ.get(DEADLINE_ENV, "").strip()
    if not raw:
        return DEFAULT_DEADLINE
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise DataFileError(f"{DEADLINE_ENV} must be a positive number of seconds (e.g. 600), not {raw!r}")
    return value


def resolve(
    name: str, data_dir: str | Path | None = None, *, download: bool | None = None, deadline: float | None = None
) -> Path:
    """Return the local path of a registered data file, downloading it into the cache if needed.

    Args:
        name: Registered dataset name (``dam/level/train``).
        data_dir: A folder searched first (the config's ``data_dir``).
        download: Allow a download; defaults to True unless ``GYM4REAL_OFFLINE`` is set.
        deadline: Seconds the download may take in all; defaults to :func:`download_deadline`.

    Raises:
        DataFileError: The file is corrupt, or found nowhere and could not be downloaded; the message
            lists every place searched and the fix.
    """
    spec = dataset(name)
    if download is None:
        download = not _offline()
    dropped = ""
    copy = find(name, data_dir)
    if copy is not None:
        if copy.where != "user cache" or not download:
            _check(spec, copy.path, copy.where)
            return copy.path
        if is_intact(spec, copy.path):
            return copy.path
        dropped = f"; the corrupt copy in the user cache (sha256 {sha256_of(copy.path)}) was removed"
        copy.path.unlink()  # our own cache: drop a corrupt copy and fetch it again
    if not download:
        raise _missing(spec, data_dir)
    try:
        return _download(spec, download_deadline() if deadline is None else deadline)
    except Exception as exc:
        raise _missing(spec, data_dir, exc, dropped) from exc


def _offline() -> bool:
    return os.environ.get(OFFLINE_ENV, "") not in ("", "0")


def _missing(
    spec: DatasetSpec, data_dir: str | Path | None, failure: Exception | None = None, dropped: str = ""
) -> DataFileError:
    """The error of a file found nowhere: the places searched, why it was not downloaded, and the fix."""
    searched = [f"{where} ({folder / spec.path})" for where, folder in places(data_dir)]
    if not os.environ.get(DATA_DIR_ENV):
        searched.insert(-1, f"{DATA_DIR_ENV} (not set)")
    head = f"data file `{spec.path}` ({spec.name}) not found"
    folder = f"set {DATA_DIR_ENV} to a folder holding `{spec.path}` ({where_to_get(spec)})"
    fetch = f"`gym4real data fetch {spec.name.split('/')[0]}`"
    host = None if failure is None else unreachable_host(failure, spec.url)
    if failure is not None and host is not None:  # a retry from here cannot help: never suggest one
        cause = _cause(failure)
        return DataUnreachableError(
            f"{head}, and {host} cannot be reached to download it ({cause}){dropped}. Searched: "
            f"{'; '.join(searched)}. Fix: {folder}, or run again where {host} can be reached.",
            host,
            cause,
        )
    if failure is not None:
        reason = f"download from {spec.url} failed ({type(failure).__name__}: {failure}){dropped}"
        fix = f"{folder}, or run {fetch} again"
    elif _offline():
        reason = f"downloads are off ({OFFLINE_ENV}={os.environ[OFFLINE_ENV]})"
        fix = f"{folder}, or run {fetch} (it downloads despite {OFFLINE_ENV})"
    else:
        reason = "no download was asked for"
        fix = f"{folder}, or run {fetch}"
    return DataFileError(f"{head}; searched: {'; '.join(searched)}; {reason}. Fix: {fix}.")


class DeadlineDownloader:
    """pooch downloader over HTTP(S) whose whole transfer must end within ``deadline`` seconds.

    requests' ``timeout`` bounds each read, so a server that sends a byte at a time is never cut off.
    Here each read returns what has arrived (``read1``) and the clock is checked between reads, so a
    download ends at most one read timeout (``min(READ_TIMEOUT, deadline)``) after its deadline.
    """

    def __init__(self, deadline: float) -> None:
        self.deadline = deadline

    def __call__(self, url: str, output_file: str, pooch: Any, check_only: bool = False) -> None:
        """Write the body of ``url`` into ``output_file`` (pooch's downloader protocol).

        Raises:
            TimeoutError: The deadline passed before the body was complete.
        """
        import requests

        end = time.monotonic() + self.deadline
        received = 0
        with requests.get(url, stream=True, timeout=min(READ_TIMEOUT, self.deadline)) as response:
            response.raise_for_status()
            with open(output_file, "wb") as out:
                while block := response.raw.read1(1 << 16, decode_content=True):
                    if time.monotonic() > end:
                        raise TimeoutError(
                            f"not complete within the deadline of {self.deadline:g} s ({received} bytes received); "
                            f"set {DEADLINE_ENV} to a longer time in seconds"
                        )
                    out.write(block)
                    received += len(block)


def _download(spec: DatasetSpec, deadline: float) -> Path:
    """Download a file into the cache through a locked staging folder; a failure leaves nothing behind."""
    import filelock
    import pooch

    cache = cache_dir()
    root = cache / STAGING
    made = _make_dirs(root)
    name = uuid.uuid4().hex
    try:
        _remove_stale_staging(root)
        with filelock.FileLock(root / f"{name}.lock"), _quiet(pooch.get_logger()):
            try:
                fetched = pooch.retrieve(
                    spec.url,
                    known_hash=f"sha256:{spec.sha256}",
                    fname=Path(spec.path).name,
                    path=root / name,
                    downloader=DeadlineDownloader(deadline),
                    progressbar=False,
                )
                target = cache / spec.path
                made += _make_dirs(target.parent)
                os.replace(fetched, target)
            finally:
                shutil.rmtree(root / name, ignore_errors=True)
    finally:
        (root / f"{name}.lock").unlink(missing_ok=True)
        _remove_empty([root, *made])
    return target


@contextlib.contextmanager
def _quiet(logger: logging.Logger) -> Iterator[None]:
    """Silence a logger's notices (pooch's "Downloading data from ..." would land inside a progress bar)."""
    level = logger.level
    logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logger.setLevel(level)


def _remove_empty(folders: list[Path]) -> None:
    """Remove those of ``folders`` that are empty, innermost first."""
    for folder in sorted(set(folders), key=lambda p: len(p.parts), reverse=True):
        with contextlib.suppress(OSError):  # not empty (or not there)
            folder.rmdir()


def _make_dirs(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; return those created, outermost first."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()][::-1]
    folder.mkdir(parents=True, exist_ok=True)
    return missing


def _remove_stale_staging(root: Path) -> None:
    """Remove the staging folders of downloads that died (killed): nobody holds their lock any more."""
    import filelock

    for lock_path in root.glob("*.lock"):
        lock = filelock.FileLock(lock_path)
        try:
            lock.acquire(timeout=0)
        except filelock.Timeout:
            continue  # a download in progress
        try:
            shutil.rmtree(root / lock_path.stem, ignore_errors=True)
        finally:
            lock.release()
        lock_path.unlink(missing_ok=True)


def upstream(
    domain: str, base_url: str, files: dict[str, tuple[str, str]], licence: str, subdir: str = ""
) -> list[DatasetSpec]:
    """Build the dataset specs of files that share one upstream base address.

    Args:
        domain: Domain key; names are ``<domain>/<key>`` and paths ``<domain>/<subdir>/<relative path>``.
        base_url: Address that each relative path is appended to.
        files: Name suffix -> (relative path, sha256).
        licence: Licence of the files.
        subdir: Folder of the files below the domain's folder (when upstream lays them out elsewhere).
    """
    folder = "/".join(p for p in (domain, subdir.strip("/")) if p)
    return [
        DatasetSpec(
            name=f"{domain}/{key}",
            path=f"{folder}/{rel}",
            sha256=sha,
            url=f"{base_url.rstrip('/')}/{rel}",
            licence=licence,
        )
        for key, (rel, sha) in files.items()
    ]
