"""Readers of quote files: HistData ASCII tick and 1-minute files, and any CSV of timestamped quotes.

Every reader returns a :class:`Quotes` record: timestamps in market time (EST without daylight
saving, UTC-05:00) as ``datetime64[ns]`` and the mid price, sorted by time. A malformed line raises
:class:`~gym4real.core.errors.DataFileError` naming the file, the line and the expected format.

HistData formats (https://www.histdata.com, timestamps in EST *without* daylight saving):

* tick (``DAT_ASCII_EURUSD_T_YYYYMM.csv``): ``YYYYMMDD HHMMSSfff,bid,ask,volume``, no header;
  mid = (bid + ask) / 2;
* 1-minute bars (``DAT_ASCII_EURUSD_M1_YYYY.csv`` or ``..._YYYYMM.csv``):
  ``YYYYMMDD HHMMSS;open;high;low;close;volume``, no header, bid prices only, so the "mid" is the bid
  close of each minute (bar labelled by its start).

HistData downloads are zip files holding the CSV; the readers take either.
"""

from __future__ import annotations

import io
import re
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from gym4real.core.errors import DataFileError
from gym4real.trading.config import MARKET_UTC_OFFSET, CsvColumns

TICK_FORMAT = "YYYYMMDD HHMMSSfff,bid,ask,volume"
M1_FORMAT = "YYYYMMDD HHMMSS;open;high;low;close;volume"
_HISTDATA_NAME = re.compile(r"^DAT_ASCII_(?P<pair>[A-Z]{6})_(?P<tf>T|M1)_(?P<year>\d{4})(?P<month>\d{2})?\.(csv|zip)$")


@dataclass(frozen=True)
class Quotes:
    """Mid prices at timestamps (market time), sorted by time."""

    time: np.ndarray  # datetime64[ns]
    mid: np.ndarray  # float64

    def __len__(self) -> int:
        return len(self.time)


def _open_text(path: Path) -> io.StringIO | Path:
    """The file itself, or the CSV inside a HistData zip."""
    if path.suffix.lower() != ".zip":
        return path
    try:
        with zipfile.ZipFile(path) as zf:
            members = [n for n in zf.namelist() if n.lower().endswith(".csv")]
            if len(members) != 1:
                raise DataFileError(f"zip file `{path}` must hold exactly one .csv file, found {members}")
            return io.StringIO(zf.read(members[0]).decode("ascii", errors="replace"))
    except zipfile.BadZipFile as exc:
        raise DataFileError(f"`{path}` is not a valid zip file ({exc}); download it again") from exc


def _read_fields(path: Path, expected: str, sep: str, names: list[str] | None, header: bool = False) -> pd.DataFrame:
    """All fields as text; a wrong field count, an unreadable or an empty file is a :class:`DataFileError`."""
    try:
        df = pd.read_csv(_open_text(path), sep=sep, header=0 if header else None, names=names, dtype=str, engine="c")
    except pd.errors.ParserError as exc:
        msg = str(exc).replace("Error tokenizing data. C error: ", "")
        raise DataFileError(f"malformed file `{path}`: {msg}; expected `{expected}`") from exc
    except (OSError, UnicodeDecodeError, pd.errors.EmptyDataError) as exc:
        raise DataFileError(f"cannot read `{path}` ({exc}); expected `{expected}`") from exc
    if df.empty:
        raise DataFileError(f"`{path}` holds no quotes; expected `{expected}`")
    return df


def _bad_line(path: Path, df: pd.DataFrame, bad: np.ndarray, expected: str, first_line: int = 1) -> DataFileError:
    row = int(np.flatnonzero(bad)[0])
    text = ",".join("" if pd.isna(v) else str(v) for v in df.iloc[row].tolist())
    return DataFileError(
        f"malformed line {row + first_line} of `{path}`: {text!r}; expected `{expected}` ({int(bad.sum())} bad line(s))"
    )


def _prices(path: Path, df: pd.DataFrame, cols: Sequence[str], expected: str, first_line: int = 1) -> np.ndarray:
    values = np.column_stack([pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float) for c in cols])
    bad = ~np.all(np.isfinite(values) & (values > 0), axis=1)
    if bad.any():
        raise _bad_line(path, df, bad, expected, first_line)
    return values


def _times(path: Path, df: pd.DataFrame, col: str, fmt: str | None, expected: str, first_line: int = 1) -> np.ndarray:
    raw = df[col]
    try:
        parsed = pd.to_datetime(raw, format=fmt, errors="coerce") if fmt else pd.to_datetime(raw, errors="coerce")
    except (ValueError, TypeError) as exc:
        raise DataFileError(f"cannot parse the timestamps of `{path}` with format {fmt!r}: {exc}") from exc
    if getattr(parsed.dt, "tz", None) is not None:  # ISO strings with an offset: to naive UTC
        parsed = parsed.dt.tz_convert("UTC").dt.tz_localize(None)
    bad = parsed.isna().to_numpy()
    if bad.any():
        raise _bad_line(path, df, bad, expected, first_line)
    return parsed.to_numpy(dtype="datetime64[ns]")


def _to_market(time: np.ndarray, utc_offset_hours: float) -> np.ndarray:
    shift = MARKET_UTC_OFFSET - utc_offset_hours
    if shift:
        time = time + np.timedelta64(round(shift * 3600), "s")
    return time


def _sorted(time: np.ndarray, mid: np.ndarray) -> Quotes:
    order = np.argsort(time, kind="stable")
    return Quotes(time[order], mid[order])


def read_histdata_tick(path: str | Path, utc_offset_hours: float = MARKET_UTC_OFFSET) -> Quotes:
    """Read a HistData ASCII tick file (``YYYYMMDD HHMMSSfff,bid,ask,volume``); mid = (bid + ask) / 2.

    Raises:
        DataFileError: A line with another number of fields, a bad timestamp or a non-positive price.
    """
    path = Path(path)
    df = _read_fields(path, TICK_FORMAT, ",", ["time", "bid", "ask", "volume"])
    if df["ask"].isna().any():
        raise _bad_line(path, df, df["ask"].isna().to_numpy(), TICK_FORMAT)
    time = _times(path, df, "time", "%Y%m%d %H%M%S%f", TICK_FORMAT)
    bid_ask = _prices(path, df, ["bid", "ask"], TICK_FORMAT)
    return _sorted(_to_market(time, utc_offset_hours), bid_ask.mean(axis=1))


def read_histdata_m1(path: str | Path, utc_offset_hours: float = MARKET_UTC_OFFSET) -> Quotes:
    """Read a HistData ASCII 1-minute file (``YYYYMMDD HHMMSS;open;high;low;close;volume``); mid = close.

    The bars hold bid prices, so the mid is the bid close of each minute (labelled by the minute's start).

    Raises:
        DataFileError: A line with another number of fields, a bad timestamp or a non-positive price.
    """
    path = Path(path)
    df = _read_fields(path, M1_FORMAT, ";", ["time", "open", "high", "low", "close", "volume"])
    if df["close"].isna().any():
        raise _bad_line(path, df, df["close"].isna().to_numpy(), M1_FORMAT)
    time = _times(path, df, "time", "%Y%m%d %H%M%S", M1_FORMAT)
    close = _prices(path, df, ["close"], M1_FORMAT)[:, 0]
    return _sorted(_to_market(time, utc_offset_hours), close)


def _column(path: Path, df: pd.DataFrame, ref: str | int, role: str) -> str:
    cols = [str(c) for c in df.columns]
    if isinstance(ref, int):
        if not 0 <= ref < len(cols):
            raise DataFileError(
                f"`{path}` has {len(cols)} columns {cols}; `source.columns.{role}` = {ref} is out of range"
            )
        return str(df.columns[ref])
    if ref not in cols:
        raise DataFileError(f"`{path}` has no column `{ref}` (`source.columns.{role}`); its columns are {cols}")
    return ref


def read_csv_quotes(path: str | Path, columns: CsvColumns, utc_offset_hours: float = 0.0) -> Quotes:
    """Read any CSV of timestamped quotes with a column mapping (see :class:`CsvColumns`).

    Raises:
        DataFileError: A missing column, a bad timestamp or price, or an unreadable file.
    """
    path = Path(path)
    what = f"a CSV with a timestamp column `{columns.timestamp}` and " + (
        f"price column `{columns.price}`" if columns.price is not None else f"columns `{columns.bid}`, `{columns.ask}`"
    )
    df = _read_fields(path, what, columns.separator, None, columns.header)
    first = 2 if columns.header else 1
    tcol = _column(path, df, columns.timestamp, "timestamp")
    time = _times(path, df, tcol, columns.timestamp_format, what, first)
    if columns.price is not None:
        mid = _prices(path, df, [_column(path, df, columns.price, "price")], what, first)[:, 0]
    else:
        assert columns.bid is not None and columns.ask is not None
        cols = [_column(path, df, columns.bid, "bid"), _column(path, df, columns.ask, "ask")]
        mid = _prices(path, df, cols, what, first).mean(axis=1)
    return _sorted(_to_market(time, utc_offset_hours), mid)


def concat(parts: Sequence[Quotes]) -> Quotes:
    """Join quotes of several files (sorted by time)."""
    if len(parts) == 1:
        return parts[0]
    return _sorted(np.concatenate([p.time for p in parts]), np.concatenate([p.mid for p in parts]))


def histdata_files(folder: Path, kind: str, pair: str, years: Sequence[int]) -> list[Path]:
    """The HistData files of ``years`` in ``folder``, matched by name (``.csv`` preferred over ``.zip``).

    Tick data needs the 12 monthly files of each year; 1-minute data a yearly file or 12 monthly files.

    Raises:
        DataFileError: Files are missing; the message lists them.
    """
    tf = "T" if kind == "histdata_tick" else "M1"
    found: dict[tuple[int, int | None], Path] = {}
    if folder.is_dir():
        for p in sorted(folder.iterdir(), key=lambda q: q.suffix != ".csv"):  # .csv first
            m = _HISTDATA_NAME.match(p.name)
            if m and m["pair"] == pair and m["tf"] == tf:
                key = (int(m["year"]), int(m["month"]) if m["month"] else None)
                found.setdefault(key, p)
    files: list[Path] = []
    missing: list[str] = []
    for year in sorted(set(years)):
        if tf == "M1" and (year, None) in found:
            files.append(found[(year, None)])
            continue
        for month in range(1, 13):
            if (year, month) in found:
                files.append(found[(year, month)])
            else:
                missing.append(f"DAT_ASCII_{pair}_{tf}_{year}{month:02d}.csv")
    if missing:
        shown = ", ".join(missing[:4]) + (f" and {len(missing) - 4} more" if len(missing) > 4 else "")
        raise DataFileError(f"missing {len(missing)} HistData file(s) in `{folder}`: {shown}")
    return files


def read_histdata(files: Sequence[Path], kind: str, utc_offset_hours: float = MARKET_UTC_OFFSET) -> Quotes:
    """Read and join HistData files of one kind."""
    reader = read_histdata_tick if kind == "histdata_tick" else read_histdata_m1
    return concat([reader(f, utc_offset_hours) for f in files])
