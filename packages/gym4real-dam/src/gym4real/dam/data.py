"""Reading and validating the Lake Como data files (one row per year, one column per day of the year).

Files are resolved through the core dataset registry (``dam/demand/train``, ...) and read once per
path (memoised on path, size and modification time). Every defect of a file (missing header, truncated
row, a gap inside a year, a value out of range, a 366-day row for a year that is not a leap year)
raises :class:`~gym4real.core.errors.DataFileError` naming the file and what was expected.
"""

from __future__ import annotations

import calendar
import csv
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from gym4real.core.errors import DataFileError

DAYS = 365
FEB29 = 59  # 0-based index of 29 February in a leap year's row


@dataclass(frozen=True)
class YearlyTable:
    """A yearly data file: the years in file order and each year's daily values (365 or 366)."""

    path: Path
    years: tuple[int, ...]
    values: Mapping[int, tuple[float, ...]]


_cache: dict[tuple[str, int, int, str], object] = {}


def _memo_key(path: Path, what: str) -> tuple[str, int, int, str]:
    try:
        st = path.stat()
    except OSError as exc:
        raise DataFileError(f"cannot read {what} file `{path}`: {exc}") from exc
    return (str(path.resolve()), st.st_size, st.st_mtime_ns, what)


def _rows(path: Path, what: str) -> list[list[str]]:
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:
            rows = [r for r in csv.reader(f) if r and any(c.strip() for c in r)]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise DataFileError(f"cannot read {what} file `{path}`: {exc}") from exc
    if not rows:
        raise DataFileError(f"{what} file `{path}` is empty; expected a header and one row per year")
    return rows


def _number(cell: str, path: Path, where: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        raise DataFileError(f"`{path}`: {where} holds `{cell}`, not a number") from None
    if math.isinf(value):
        raise DataFileError(f"`{path}`: {where} is infinite")
    return value


def read_yearly(path: Path, what: str, low: float | None = None, high: float | None = None) -> YearlyTable:
    """Read a yearly file (header ``year,0,1,...,365``), checking its shape and value range.

    Args:
        path: The CSV file.
        what: What it holds (``demand``, ``inflow``, ``level``), for messages.
        low: Smallest accepted value (None: no bound).
        high: Largest accepted value (None: no bound).

    Raises:
        DataFileError: A missing or wrong header, a truncated or malformed row, a duplicate year, a gap
            inside a year, a year with neither 365 nor 366 values, or a value out of range.
    """
    key = (*_memo_key(path, what)[:3], f"{what}:{low}:{high}")
    if key in _cache:
        return _cache[key]  # type: ignore[return-value]
    rows = _rows(path, what)
    header = [c.strip() for c in rows[0]]
    days = len(header) - 1
    expected = [str(i) for i in range(days)]
    if header[0] != "year" or header[1:] != expected or days not in (DAYS, DAYS + 1):
        msg = (
            f"{what} file `{path}` has header `{','.join(header[:4])},...` ({len(header)} columns); expected "
            f"`year,0,1,...,365` (a year column and 366 day columns)"
        )
        raise DataFileError(msg)
    if len(rows) < 2:
        raise DataFileError(f"{what} file `{path}` has a header but no year rows")
    values: dict[int, tuple[float, ...]] = {}
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            msg = (
                f"line {line} of {what} file `{path}` has {len(row)} fields, expected {len(header)} "
                f"(the file is truncated or malformed)"
            )
            raise DataFileError(msg)
        try:
            year = int(row[0])
        except ValueError:
            raise DataFileError(f"line {line} of `{path}`: year `{row[0]}` is not an integer") from None
        if year in values:
            raise DataFileError(f"{what} file `{path}` holds year {year} twice (line {line})")
        cells = [c.strip() for c in row[1:]]
        present = [c not in ("", "nan", "NaN", "NA") for c in cells]
        n = sum(present)
        if not all(present[:n]) or n not in (DAYS, DAYS + 1):
            msg = (
                f"{what} file `{path}`, year {year}: expected 365 or 366 leading values and only empty/NaN "
                f"cells after them, found {n} values with a gap"
                if not all(present[:n])
                else f"{what} file `{path}`, year {year}: {n} values, expected 365 or 366"
            )
            raise DataFileError(msg)
        series = tuple(_number(c, path, f"year {year}, day {i}") for i, c in enumerate(cells[:n]))
        for i, v in enumerate(series):
            if (low is not None and v < low) or (high is not None and v > high):
                bound = f"[{low}, {high}]"
                msg = f"{what} file `{path}`, year {year}, day {i}: value {v} outside the accepted range {bound}"
                if high is not None and v > high:
                    msg += " (raise `max_inflow` / `max_demand` if the data are right)"
                raise DataFileError(msg)
        values[year] = series
    table = YearlyTable(path, tuple(values), values)
    _cache[key] = table
    return table


def read_daily_column(path: Path, what: str, column: str | None = None) -> tuple[float, ...]:
    """Read 365 non-negative daily values from one column of a CSV with a header (MEF, evaporation rates).

    Args:
        path: The CSV file.
        what: What it holds, for messages.
        column: The column to read; None: the file must have exactly one column.
    """
    key = _memo_key(path, f"{what}:{column}")
    if key in _cache:
        return _cache[key]  # type: ignore[return-value]
    rows = _rows(path, what)
    header = [c.strip() for c in rows[0]]
    if column is None:
        if len(header) != 1:
            raise DataFileError(f"{what} file `{path}` has columns {header}; expected a single column")
        index = 0
    elif column in header:
        index = header.index(column)
    else:
        raise DataFileError(f"{what} file `{path}` has no column `{column}` (columns: {header})")
    cells = [r[index].strip() if index < len(r) else "" for r in rows[1:]]
    if len(cells) < DAYS or any(c == "" for c in cells[:DAYS]):
        raise DataFileError(f"{what} file `{path}` holds {len(cells)} rows; expected 365 daily values")
    series = tuple(_number(c, path, f"row {i + 2}") for i, c in enumerate(cells[:DAYS]))
    if any(v < 0 or math.isnan(v) for v in series):
        raise DataFileError(f"{what} file `{path}` holds a negative or NaN value; expected rates >= 0")
    _cache[key] = series
    return series


def calendar_days(table: YearlyTable, year: int, drop_feb29: bool) -> list[float]:
    """Return the 365 daily values of a year, handling the 366-value rows of leap years explicitly.

    Args:
        table: The yearly file.
        year: A year of the file.
        drop_feb29: True: drop 29 February (index 59), so that day ``d`` of every year is the same
            calendar day; a 366-value row for a year that is not a leap year is an error. False: keep
            the first 365 values (the reference; in leap years day ``d >= 60`` is one calendar day early).
    """
    series = table.values[year]
    if len(series) == DAYS:
        return list(series)
    if not drop_feb29:
        return list(series[:DAYS])
    if not calendar.isleap(year):
        msg = f"`{table.path}`: year {year} has 366 values but is not a leap year; expected 365"
        raise DataFileError(msg)
    return list(series[:FEB29] + series[FEB29 + 1 :])
