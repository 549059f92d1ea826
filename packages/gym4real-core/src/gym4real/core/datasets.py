"""Resolution of data files: explicit folder, ``GYM4REAL_DATA_DIR``, user cache, then download.

Every file is checked against the SHA-256 its plugin registered. A download goes through pooch into
the user cache (``platformdirs``); pooch writes to a temporary file and moves it into place only
after the hash matched, so a failed or corrupt download leaves nothing behind.
``GYM4REAL_OFFLINE=1`` forbids downloads.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import platformdirs

from gym4real.core.errors import DataFileError
from gym4real.core.registry import registry
from gym4real.core.specs import DatasetSpec

DATA_DIR_ENV = "GYM4REAL_DATA_DIR"
OFFLINE_ENV = "GYM4REAL_OFFLINE"

_verified: dict[tuple[str, int, int], str] = {}


def cache_dir() -> Path:
    """Return the user cache folder of downloaded data (``GYM4REAL_CACHE_DIR`` overrides it)."""
    return Path(os.environ.get("GYM4REAL_CACHE_DIR") or platformdirs.user_cache_dir("gym4real"))


def sha256_of(path: Path) -> str:
    """Return the hex SHA-256 of a file, memoised on its path, size and modification time."""
    st = path.stat()
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    if key not in _verified:
        h = hashlib.sha256()
        with path.open("rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        _verified[key] = h.hexdigest()
    return _verified[key]


def dataset(name: str) -> DatasetSpec:
    """Return the registered spec of a dataset name."""
    datasets = registry().datasets
    if name not in datasets:
        raise DataFileError(f"unknown dataset `{name}`; registered: {sorted(datasets)}")
    return datasets[name]


def _places(data_dir: str | Path | None) -> list[tuple[str, Path]]:
    places = []
    if data_dir:
        places.append(("config `data_dir`", Path(data_dir).expanduser()))
    if os.environ.get(DATA_DIR_ENV):
        places.append((DATA_DIR_ENV, Path(os.environ[DATA_DIR_ENV]).expanduser()))
    places.append(("user cache", cache_dir()))
    return places


def _check(spec: DatasetSpec, path: Path, where: str) -> None:
    got = sha256_of(path)
    if got != spec.sha256:
        raise DataFileError(
            f"data file `{spec.path}` ({spec.name}) in {where} `{path}` is corrupt: sha256 {got}, expected "
            f"{spec.sha256}. Replace it with the upstream file {spec.url}"
        )


def resolve(name: str, data_dir: str | Path | None = None, *, download: bool | None = None) -> Path:
    """Return the local path of a registered data file, downloading it into the cache if needed.

    Args:
        name: Registered dataset name (``dam/level/train``).
        data_dir: A folder searched first (the config's ``data_dir``).
        download: Allow a download; defaults to True unless ``GYM4REAL_OFFLINE`` is set.

    Raises:
        DataFileError: The file is corrupt, or found nowhere and could not be downloaded; the message
            lists every place searched and the fix.
    """
    spec = dataset(name)
    searched = []
    for where, folder in _places(data_dir):
        path = folder / spec.path
        searched.append(f"{where} ({path})")
        if path.is_file():
            if where == "user cache" and sha256_of(path) != spec.sha256:
                path.unlink()  # our own cache: drop a corrupt copy and fetch it again
                continue
            _check(spec, path, where)
            return path
    if download is None:
        download = os.environ.get(OFFLINE_ENV, "") in ("", "0")
    reason = f"downloads are off ({OFFLINE_ENV} is set)"
    if download:
        try:
            return _download(spec)
        except Exception as exc:
            reason = f"download from {spec.url} failed ({type(exc).__name__}: {exc})"
    raise DataFileError(
        f"data file `{spec.path}` ({spec.name}) not found; searched: {'; '.join(searched)}; {reason}. "
        f"Fix: set {DATA_DIR_ENV} to a folder holding `{spec.path}`, or run `gym4real data fetch "
        f"{spec.name.split('/')[0]}` where the network is reachable."
    )


def _download(spec: DatasetSpec) -> Path:
    import pooch

    target = cache_dir() / spec.path
    target.parent.mkdir(parents=True, exist_ok=True)
    fetched = pooch.retrieve(
        spec.url,
        known_hash=f"sha256:{spec.sha256}",
        fname=target.name,
        path=target.parent,
        downloader=pooch.HTTPDownloader(timeout=60, progressbar=False),
        progressbar=False,
    )
    return Path(fetched)


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
