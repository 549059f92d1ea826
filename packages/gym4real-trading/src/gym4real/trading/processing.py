"""From quotes to a clean bar grid of mid prices, with a parquet cache.

Processing, in order:

1. last quote of each bar (bars labelled by their start, as ``resample(...).last()``) on a complete
   grid of bars from the first day's midnight to the last day's end (market time);
2. forward fill of gaps up to ``ffill_limit`` minutes: on the continuous grid (corrected: a session
   may open with the price quoted just before it) or, as the reference, on the concatenated session
   rows (the previous session's last price fills the first minutes of the next one);
3. trading days: Monday-Friday sessions ``trading_open <= time < trading_close``; a session that still
   has a missing bar is dropped, with the reason (no quotes at all, or the longest gap).

The result (grid and day report) is cached as parquet in ``<user cache>/trading/processed/``, keyed by
the SHA-256 of the source files and the processing parameters. A cache file holds its key and a
SHA-256 of its content; one that does not match (altered, damaged, or written for another key) is
rebuilt. File hashes are memoised in ``<user cache>/trading/hashes.json`` on the file's size,
modification and change times and inode, so that a file rewritten in place is hashed again.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import logging
import os
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gym4real.core import datasets
from gym4real.core.errors import DataFileError
from gym4real.trading import quotes as q
from gym4real.trading.config import SourceSection

logger = logging.getLogger("gym4real.trading")

#: Bump when the processing changes, so that old cache files are not reused.
PROCESSING_VERSION = 2
_NS_PER_MIN = 60_000_000_000
HISTDATA_SUBDIR = "trading/histdata"
HISTDATA_PAGE = "https://www.histdata.com/download-free-forex-historical-data/?/ascii/tick-data-quotes/EURUSD"


@dataclass(frozen=True)
class Processing:
    """Parameters of the processing (all part of the cache key)."""

    bar_minutes: int = 1
    ffill_limit: int = 5
    trading_open: int = 8
    trading_close: int = 18
    continuous_ffill: bool = True

    @property
    def bars_per_day(self) -> int:
        """Bars in 24 hours."""
        return 1440 // self.bar_minutes

    @property
    def session(self) -> slice:
        """The session's bars within a day."""
        b = self.bar_minutes
        return slice(self.trading_open * 60 // b, self.trading_close * 60 // b)


@dataclass
class Processed:
    """A complete bar grid of mid prices (NaN where still missing) and the day report.

    ``mid`` has ``n_days * bars_per_day`` bars starting at midnight of ``first_day``; ``kept`` are the
    complete trading sessions and ``dropped`` maps every other weekday to the reason.
    """

    first_day: dt.date
    mid: np.ndarray
    params: Processing
    kept: list[dt.date]
    dropped: dict[dt.date, str]
    sources: list[str] = field(default_factory=list)
    spacing_minutes: float = 0.0
    key: str = ""

    @property
    def n_days(self) -> int:
        """Calendar days of the grid."""
        return len(self.mid) // self.params.bars_per_day

    def day_index(self, day: dt.date) -> int:
        """Row of a calendar day in the grid reshaped to days."""
        return (day - self.first_day).days


def _ffill(values: np.ndarray, limit: int) -> np.ndarray:
    """Forward-fill NaN runs, at most ``limit`` steps after the last valid value."""
    n = len(values)
    pos = np.arange(n)
    last = np.where(~np.isnan(values), pos, -1)
    np.maximum.accumulate(last, out=last)
    ok = (last >= 0) & (pos - last <= limit)
    out = np.full(n, np.nan)
    out[ok] = values[last[ok]]
    return out


def _longest_run(missing: np.ndarray) -> int:
    best = run = 0
    for m in missing.tolist():
        run = run + 1 if m else 0
        best = max(best, run)
    return best


def process(quotes: q.Quotes, params: Processing, sources: Sequence[str] = ()) -> Processed:
    """Build the bar grid and the day report from quotes (see the module docstring).

    Raises:
        DataFileError: No quotes.
    """
    if len(quotes) == 0:
        raise DataFileError(f"no quotes in {list(sources)}")
    bar_ns = params.bar_minutes * _NS_PER_MIN
    t = quotes.time.astype("datetime64[ns]").astype(np.int64)
    bars = t // bar_ns
    last = np.r_[bars[1:] != bars[:-1], True]  # sorted input: the last quote of each bar
    first_day = quotes.time[0].astype("datetime64[D]")
    last_day = quotes.time[-1].astype("datetime64[D]")
    n_days = int((last_day - first_day).astype(int)) + 1
    bpd = params.bars_per_day
    start_bar = first_day.astype("datetime64[ns]").astype(np.int64) // bar_ns
    raw = np.full(n_days * bpd, np.nan)
    raw[bars[last] - start_bar] = quotes.mid[last]

    dates = np.arange(first_day, last_day + 1)
    weekday = ((dates.astype(int) + 3) % 7) < 5  # 1970-01-01 was a Thursday
    ses = params.session
    limit = params.ffill_limit // params.bar_minutes
    if params.continuous_ffill:
        mid = _ffill(raw, limit)
    else:  # the reference: fill along the concatenated weekday sessions
        mid = raw.copy()
        grid = mid.reshape(n_days, bpd)
        block = grid[weekday, ses]
        grid[weekday, ses] = _ffill(block.ravel(), limit).reshape(block.shape)
    raw_s = raw.reshape(n_days, bpd)[:, ses]
    mid_s = mid.reshape(n_days, bpd)[:, ses]
    kept: list[dt.date] = []
    dropped: dict[dt.date, str] = {}
    complete = ~np.isnan(mid_s).any(axis=1)
    empty = np.isnan(raw_s).all(axis=1)
    for i in np.flatnonzero(weekday):
        day = dates[i].astype(object)
        if complete[i]:
            kept.append(day)
        elif empty[i]:
            dropped[day] = "no quotes in the session (market holiday or no data)"
        else:
            gap = _longest_run(np.isnan(raw_s[i])) * params.bar_minutes
            dropped[day] = f"gap of {gap} min, longer than ffill_limit ({params.ffill_limit} min)"
    filled = np.flatnonzero(~np.isnan(raw))
    spacing = float(np.median(np.diff(filled))) * params.bar_minutes if len(filled) > 1 else 0.0
    return Processed(first_day.astype(object), mid, params, kept, dropped, list(sources), spacing)


def drop_summary(dropped: dict[dt.date, str]) -> dict[str, int]:
    """Count of dropped days per reason (gap lengths grouped)."""
    return dict(Counter("gap longer than ffill_limit" if r.startswith("gap") else r for r in dropped.values()))


# -- files and hashes ------------------------------------------------------------------------------


def _hash_memo_path() -> Path:
    return datasets.cache_dir() / "trading" / "hashes.json"


def _read_hash_memo() -> dict[str, Any]:
    try:
        memo = json.loads(_hash_memo_path().read_text())
    except (OSError, ValueError):
        return {}
    return memo if isinstance(memo, dict) else {}


def file_sha256(path: Path) -> str:
    """SHA-256 of a file, memoised on disk so large HistData files hash once.

    The memo holds the file's size, modification and change times and inode: a file rewritten in place
    changes its change time (which no user call can set back), so it is hashed again.
    """
    st = path.stat()
    stamp = [st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino]
    key = str(path.resolve())
    memo = _read_hash_memo()
    entry = memo.get(key)
    if isinstance(entry, dict) and entry.get("stat") == stamp and isinstance(entry.get("sha256"), str):
        return entry["sha256"]
    digest = datasets.sha256_of(path)
    memo[key] = {"stat": stamp, "sha256": digest}
    try:
        memo_path = _hash_memo_path()
        memo_path.parent.mkdir(parents=True, exist_ok=True)
        tmp = memo_path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps(memo))
        tmp.replace(memo_path)
    except OSError:
        pass
    return digest


def histdata_folders(data_dir: str | Path | None) -> list[Path]:
    """Folders searched for HistData files: `<data_dir>`, `$GYM4REAL_DATA_DIR`, the cache (each `/trading/histdata`)."""
    roots = [Path(data_dir).expanduser()] if data_dir else []
    if os.environ.get(datasets.DATA_DIR_ENV):
        roots.append(Path(os.environ[datasets.DATA_DIR_ENV]).expanduser())
    roots.append(datasets.cache_dir())
    return [r / HISTDATA_SUBDIR for r in roots]


def source_files(source: SourceSection, years: Sequence[int], data_dir: str | Path | None) -> list[tuple[Path, str]]:
    """The files of a source for some years, with their SHA-256.

    Raises:
        DataFileError: Files not found; the message says where it looked and how to get them.
    """
    if source.kind == "csv":
        if source.dataset is not None:
            spec = datasets.dataset(source.dataset)
            return [(datasets.resolve(source.dataset, data_dir), spec.sha256)]
        assert source.path is not None
        path = Path(source.path).expanduser()
        if not path.is_absolute() and data_dir and (Path(data_dir) / path).is_file():
            path = Path(data_dir) / path
        if not path.is_file():
            problem = "is a folder, not a CSV file" if path.is_dir() else "not found"
            raise DataFileError(f"quote file `{path}` (`source.path`) {problem}")
        return [(path, file_sha256(path))]
    folders = [Path(source.path).expanduser()] if source.path else histdata_folders(data_dir)
    problems = []
    for folder in folders:
        try:
            files = q.histdata_files(folder, source.kind, source.pair, years)
        except DataFileError as exc:
            problems.append(str(exc) if folder.is_dir() else f"`{folder}` does not exist")
            continue
        return [(f, file_sha256(f)) for f in files]
    kind = "tick" if source.kind == "histdata_tick" else "m1"
    years_arg = " ".join(str(y) for y in sorted(set(years)))
    msg = (
        f"HistData {kind} files of {source.pair} for {sorted(set(years))} not found; looked in: {'; '.join(problems)}. "
        f"Fix: `python -m gym4real.trading.fetch --years {years_arg} --kind {kind}` (needs the `histdata` extra and "
        f"network), or download them from {HISTDATA_PAGE} into `{folders[-1]}` (or set `source.path`)"
    )
    raise DataFileError(msg)


def read_source(source: SourceSection, files: Sequence[Path]) -> q.Quotes:
    """Read the quotes of a source's files."""
    if source.kind == "csv":
        return q.read_csv_quotes(files[0], source.columns, source.utc_offset_hours)
    return q.read_histdata(files, source.kind, source.utc_offset_hours)


# -- cache -----------------------------------------------------------------------------------------

_memo: dict[str, Processed] = {}


def cache_key(source: SourceSection, files: Sequence[tuple[Path, str]], params: Processing) -> str:
    """Hex key of the processed frame: source file hashes, reading options and processing parameters."""
    record: dict[str, Any] = {
        "version": PROCESSING_VERSION,
        "kind": source.kind,
        "files": sorted(sha for _, sha in files),
        "utc_offset_hours": source.utc_offset_hours,
        "columns": source.columns.model_dump() if source.kind == "csv" else None,
        "params": asdict(params),
    }
    return hashlib.sha256(json.dumps(record, sort_keys=True, default=str).encode()).hexdigest()[:24]


def cache_path(key: str) -> Path:
    """Where the processed frame of a key is cached."""
    return datasets.cache_dir() / "trading" / "processed" / f"{key}.parquet"


def _content_digest(meta: dict[str, Any], mid: np.ndarray) -> str:
    """SHA-256 of a cache file's metadata (but its digest) and prices."""
    h = hashlib.sha256(json.dumps({k: v for k, v in meta.items() if k != "digest"}, sort_keys=True).encode())
    h.update(np.ascontiguousarray(mid, dtype=np.float64).tobytes())
    return h.hexdigest()


def _save(proc: Processed, path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    b = proc.params.bar_minutes
    start = np.datetime64(proc.first_day, "ns")
    time = start + np.arange(len(proc.mid)) * np.timedelta64(b, "m")
    meta = {
        "first_day": proc.first_day.isoformat(),
        "params": asdict(proc.params),
        "kept": [d.isoformat() for d in proc.kept],
        "dropped": {d.isoformat(): r for d, r in proc.dropped.items()},
        "sources": proc.sources,
        "spacing_minutes": proc.spacing_minutes,
        "version": PROCESSING_VERSION,
        "key": proc.key,
    }
    meta["digest"] = _content_digest(meta, proc.mid)
    table = pa.table({"time": time, "mid": proc.mid}).replace_schema_metadata({"gym4real": json.dumps(meta)})
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    pq.write_table(table, tmp)
    tmp.replace(path)


def _load(path: Path, key: str) -> Processed:
    """Read a cache file and verify it.

    Raises:
        ValueError: The file was written for another key or its content does not match its digest.
    """
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    meta = json.loads(table.schema.metadata[b"gym4real"])
    mid = table.column("mid").to_numpy()
    if meta.get("key") != key:
        raise ValueError(f"written for key {meta.get('key')}, not {key} (another source, version or parameters)")
    if meta.get("digest") != _content_digest(meta, mid):
        raise ValueError("its content does not match its SHA-256 (altered or damaged)")
    return Processed(
        first_day=dt.date.fromisoformat(meta["first_day"]),
        mid=mid,
        params=Processing(**meta["params"]),
        kept=[dt.date.fromisoformat(d) for d in meta["kept"]],
        dropped={dt.date.fromisoformat(d): r for d, r in meta["dropped"].items()},
        sources=list(meta["sources"]),
        spacing_minutes=float(meta["spacing_minutes"]),
    )


def load(source: SourceSection, years: Sequence[int], params: Processing, data_dir: str | Path | None) -> Processed:
    """The processed grid of a source (memoised in the process, cached as parquet on disk).

    Raises:
        DataFileError: Missing or malformed files.
    """
    files = source_files(source, years, data_dir)
    key = cache_key(source, files, params)
    if key in _memo:
        return _memo[key]
    path = cache_path(key)
    proc = None
    if path.is_file():
        try:
            proc = _load(path, key)
            proc.key = key
        except Exception as exc:  # a corrupt, altered or foreign cache file is rebuilt
            logger.warning("rebuilding the cache file %s: %s", path, exc)
    if proc is None:
        names = [p.name for p, _ in files]
        proc = process(read_source(source, [p for p, _ in files]), params, names)
        proc.key = key
        try:
            _save(proc, path)
        except OSError as exc:
            logger.warning("cannot write the cache file %s: %s", path, exc)
        counts = drop_summary(proc.dropped)
        logger.info(
            "processed %s: %d trading days kept, %d dropped %s",
            ", ".join(names[:3]) + ("..." if len(names) > 3 else ""),
            len(proc.kept),
            len(proc.dropped),
            counts,
        )
    _memo[key] = proc
    return proc
