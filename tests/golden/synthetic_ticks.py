"""Synthetic EUR/USD tick files in HistData's exact format, the market data of the trading fixture.

No market data of the paper's kind is public in this project (the reference reads HistData tick files
that users download), so the reference and our env both read these files. They are written from
integer arithmetic only (prices in units of 1e-5, a fixed linear congruential generator), so the text
is the same on every platform and Python version. Standard library only: ``regen.py`` runs it in the
reference's environment, the tests in ours.

The twelve monthly files of 2022 hold:

* nine trading days in January (3-7, 10-13 January) with 1-3 ticks in most minutes from 07:40 to 18:20,
  minutes without a tick (gaps up to 4 minutes, forward-filled by both loaders) and ticks at :00.000
  and :59.999 (the last tick of a minute wins);
* 12 January with a gap of 12 minutes (longer than the 5-minute forward-fill limit: the day is dropped);
* a Sunday evening of ticks (8-9 January; weekends are not traded);
* one tick at 03:00 on the first Monday of every other month and on 30 December, the last weekday (those
  days have no session data and are dropped; the files cover the year).
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

YEAR = 2022
PAIR = "EURUSD"
SESSION_DAYS = (3, 4, 5, 6, 7, 10, 11, 12, 13)  # January 2022, Monday 3 to Thursday 13
LONG_GAP_DAY = 12  # a 12-minute gap at 11:00: dropped by both loaders
_A, _C, _M = 1103515245, 12345, 2**31  # the classic LCG


class _Lcg:
    def __init__(self, seed: int) -> None:
        self.state = seed

    def next(self, n: int) -> int:
        """An integer in [0, n)."""
        self.state = (_A * self.state + _C) % _M
        return (self.state >> 8) % n


def _price(units: int) -> str:
    return f"{units // 100_000}.{units % 100_000:05d}"


def _tick(day: dt.date, seconds: int, millis: int, bid: int, spread: int) -> str:
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{day:%Y%m%d} {h:02d}{m:02d}{s:02d}{millis:03d},{_price(bid)},{_price(bid + spread)},0"


def _session(day: dt.date, rng: _Lcg, bid: int, gap_at: int | None) -> tuple[list[str], int]:
    lines = []
    skip, quiet_before = 0, False
    for minute in range(7 * 60 + 40, 18 * 60 + 20):
        if gap_at is not None and gap_at <= minute < gap_at + 12:
            continue
        if skip:
            skip -= 1
            continue
        if not quiet_before and rng.next(40) == 0:  # a quiet stretch of 1-4 minutes without ticks
            skip, quiet_before = rng.next(4), True
            continue
        quiet_before = False
        stamps = sorted({rng.next(60_000) for _ in range(1 + rng.next(3))})
        if rng.next(25) == 0:
            stamps = [0, *stamps, 59_999]
        for stamp in sorted(set(stamps)):
            bid += rng.next(7) - 3
            lines.append(_tick(day, minute * 60 + stamp // 1000, stamp % 1000, bid, 10 + rng.next(6)))
    return lines, bid


def month_lines(month: int) -> list[str]:
    """The lines of the file of ``month`` (1-12) of 2022, in time order."""
    if month != 1:
        first_monday = next(dt.date(YEAR, month, d) for d in range(1, 8) if dt.date(YEAR, month, d).weekday() == 0)
        lines = [_tick(first_monday, 3 * 3600, 0, 113_000 + month, 12)]
        if month == 12:  # the last weekday too: the quotes cover the year
            lines.append(_tick(dt.date(YEAR, 12, 30), 3 * 3600, 0, 113_000, 12))
        return lines
    rng, bid, lines = _Lcg(20220103), 113_042, []
    for d in SESSION_DAYS:
        day = dt.date(YEAR, 1, d)
        if d == 10:  # the Sunday evening before: weekend rows, dropped
            sunday = dt.date(YEAR, 1, 9)
            lines += [_tick(sunday, 17 * 3600 + 60 * k, 500, bid + k, 20) for k in range(0, 300, 7)]
        session, bid = _session(day, rng, bid, 11 * 60 if d == LONG_GAP_DAY else None)
        lines += session
    return lines


def write(folder: Path) -> list[Path]:
    """Write the twelve files ``DAT_ASCII_EURUSD_T_2022MM.csv`` into ``folder`` (created if needed)."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for month in range(1, 13):
        path = folder / f"DAT_ASCII_{PAIR}_T_{YEAR}{month:02d}.csv"
        path.write_text("\n".join(month_lines(month)) + "\n", encoding="ascii")
        paths.append(path)
    return paths
