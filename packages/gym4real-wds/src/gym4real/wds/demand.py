"""Weekly demand profiles: hourly multipliers of the junction base demands (STREaM, Gym4ReaL data).

Training profiles come from 33 CSV files (168 hourly rows x 54 weekly columns each, plus an index
column) sorted into the buckets ``normal`` / ``stressful`` / ``extreme`` by the catalogue
``anytown_demands.yaml``; the test set is ``test1000.csv`` (168 rows x 1000 columns, no index column).
Training weeks keep the files' column order, which is lexicographic (``"0"``, ``"1"``, ``"10"``, ...): the
reference draws a week by its position in the file, and the env draws the same position; ``train_weeks``
holds the column names. Test profiles are ordered by name (``profile_index`` k is the column named ``k``).
Values are kept as published, including the small negative multipliers of some files.
Everything is read once per process and per file.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gym4real.core.config import read_yaml
from gym4real.core.datasets import resolve
from gym4real.core.errors import DataFileError

BUCKETS = ("normal", "stressful", "extreme")
HOURS = 168


@dataclass(frozen=True)
class Profiles:
    """The demand profiles: training files per bucket and the test matrix (hours x profiles)."""

    buckets: dict[str, tuple[str, ...]]
    train: dict[str, np.ndarray]
    train_weeks: dict[str, tuple[int, ...]]
    test: np.ndarray
    low: float
    high: float


def _read_matrix(path: Path, index_column: bool) -> tuple[np.ndarray, tuple[int, ...]]:
    """Read one profile CSV into an (hours, weeks) array in the file's column order, and the column names."""
    what = f"demand profile file `{path}`"
    try:
        with path.open(encoding="utf-8") as f:
            header = f.readline().rstrip("\r\n").split(",")
            data = np.loadtxt(f, delimiter=",", ndmin=2, dtype=np.float64)
    except (OSError, ValueError) as exc:
        msg = f"{what} is malformed: {exc}; expected a CSV of {HOURS} rows of numeric multipliers"
        raise DataFileError(msg) from None
    names = header[1:] if index_column else header
    try:
        weeks = [int(n.strip().strip('"')) for n in names]
    except ValueError:
        msg = f"{what}: the header must name the weeks with integers (`0`, `1`, ...), got {header[:4]}..."
        raise DataFileError(msg) from None
    if index_column:
        data = data[:, 1:]
    if data.shape != (HOURS, len(weeks)):
        msg = (
            f"{what} has {data.shape[0]} rows x {data.shape[1]} value columns; expected {HOURS} hourly rows x "
            f"{len(weeks)} columns (one per week named in the header)"
            + (" after the leading index column" if index_column else "")
        )
        raise DataFileError(msg)
    if not np.isfinite(data).all():
        raise DataFileError(f"{what} holds non-numeric or infinite multipliers")
    out = np.ascontiguousarray(data)
    out.setflags(write=False)
    return out, tuple(weeks)


def _read_catalogue(path: Path) -> dict[str, tuple[str, ...]]:
    train = read_yaml(path, "demand catalogue", DataFileError).get("train")
    if not isinstance(train, dict) or any(not isinstance(train.get(b), list) or not train[b] for b in BUCKETS):
        msg = f"demand catalogue `{path}` must map `train` to non-empty file lists for the buckets {list(BUCKETS)}"
        raise DataFileError(msg)
    return {b: tuple(str(f) for f in train[b]) for b in BUCKETS}


def dataset_key(file_name: str) -> str:
    """Registered dataset name of a profile file (``interval_0_3-1.csv`` -> ``wds/demand/interval_0_3-1``)."""
    return f"wds/demand/{Path(file_name).stem}"


@functools.lru_cache(maxsize=4)
def _load(paths: tuple[tuple[str, str], ...], catalogue: str) -> Profiles:
    buckets = _read_catalogue(Path(catalogue))
    files = dict(paths)
    read = {name: _read_matrix(Path(files[name]), index_column=True) for b in buckets.values() for name in b}
    train = {name: matrix for name, (matrix, _) in read.items()}
    test, names = _read_matrix(Path(files["test1000.csv"]), index_column=False)
    test = np.ascontiguousarray(test[:, np.argsort(names, kind="stable")])
    test.setflags(write=False)
    values = [test, *train.values()]
    return Profiles(
        buckets=buckets,
        train=train,
        train_weeks={name: weeks for name, (_, weeks) in read.items()},
        test=test,
        low=float(min(v.min() for v in values)),
        high=float(max(v.max() for v in values)),
    )


def load(data_dir: str | None = None) -> Profiles:
    """The registered profiles (memoised per process on the resolved file paths).

    Raises:
        DataFileError: A file is missing, corrupt (hash), malformed, or the catalogue names an unknown file.
    """
    catalogue = resolve("wds/demand/catalogue", data_dir)
    buckets = _read_catalogue(catalogue)
    paths = []
    for name in [*(f for b in buckets.values() for f in b), "test1000.csv"]:
        try:
            paths.append((name, str(resolve(dataset_key(name), data_dir))))
        except DataFileError as exc:
            if "unknown dataset" in str(exc):
                msg = f"demand catalogue `{catalogue}` lists `{name}`, which is not a registered WDS profile file"
                raise DataFileError(msg) from None
            raise
    return _load(tuple(paths), str(catalogue))


def moving_average(pattern: np.ndarray, window: int) -> np.ndarray:
    """Trailing mean over the current and ``window - 1`` previous values (fewer at the start, no wrap).

    Equals pandas' ``rolling(window, min_periods=1).mean()``.
    """
    c = np.concatenate([[0.0], np.cumsum(pattern)])
    idx = np.arange(1, len(pattern) + 1)
    start = np.maximum(idx - window, 0)
    return (c[idx] - c[start]) / (idx - start)


def exp_moving_average(pattern: np.ndarray, span: int) -> np.ndarray:
    """Exponentially weighted mean, ``alpha = 2 / (span + 1)``; pandas' ``ewm(span, adjust=True).mean()``."""
    decay = 1.0 - 2.0 / (span + 1.0)
    out = np.empty(len(pattern))
    num = den = 0.0
    for i, x in enumerate(pattern):
        num = x + decay * num
        den = 1.0 + decay * den
        out[i] = num / den
    return out


def multipliers(estimates: np.ndarray, estimate: str, window: int) -> np.ndarray:
    """The multipliers a run of demand estimates was computed from, from the first pattern step on.

    The inverse of :func:`moving_average` (``estimate="sma"``) and :func:`exp_moving_average` (``"ewma"``):
    ``multipliers(moving_average(p, w), "sma", w)`` is ``p`` up to rounding. An agent recovers in this way the
    multipliers of every hour so far from the demand estimates it has observed.

    Raises:
        ValueError: ``estimate`` is neither ``"sma"`` nor ``"ewma"``, or ``window`` is below 1.
    """
    if estimate not in ("sma", "ewma") or window < 1:
        raise ValueError(f'`estimate` must be "sma" or "ewma" and `window` >= 1, not {estimate!r} and {window}')
    values = np.asarray(estimates, dtype=np.float64)
    out = np.empty(len(values))
    if estimate == "sma":
        for i, mean in enumerate(values):
            n = min(i + 1, window)
            out[i] = n * mean - out[i - n + 1 : i].sum()
        return out
    decay = 1.0 - 2.0 / (window + 1.0)
    previous = den = 0.0
    for i, mean in enumerate(values):
        den = 1.0 + decay * den
        weighted = mean * den  # the decayed sum of the multipliers so far
        out[i] = weighted - decay * previous
        previous = weighted
    return out
