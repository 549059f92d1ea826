"""Download the paper's HistData EUR/USD files (the optional ``histdata`` extra).

``python -m gym4real.trading.fetch --years 2019 2020 2021 2022`` (what ``gym4real data fetch trading
--years ...`` should call: :func:`fetch`) writes ``DAT_ASCII_EURUSD_T_YYYYMM.csv`` (tick) or
``DAT_ASCII_EURUSD_M1_YYYY.csv`` (1-minute) into ``<user cache>/trading/histdata`` (or ``--dest``),
where the ``paper_*`` presets look. Files already there are kept. Without network, or with
``GYM4REAL_OFFLINE=1``, it stops with a one-line error before downloading anything.
"""

from __future__ import annotations

import argparse
import os
import socket
import sys
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from gym4real.core import datasets
from gym4real.core.errors import DataFileError, Gym4RealError
from gym4real.trading.processing import HISTDATA_PAGE, HISTDATA_SUBDIR

HOST = "www.histdata.com"


def default_dest() -> Path:
    """``<user cache>/trading/histdata``."""
    return datasets.cache_dir() / HISTDATA_SUBDIR


def _check_network(timeout: float) -> None:
    if os.environ.get(datasets.OFFLINE_ENV, "") not in ("", "0"):
        raise DataFileError(f"cannot download from {HOST}: downloads are off ({datasets.OFFLINE_ENV} is set)")
    try:
        socket.create_connection((HOST, 443), timeout=timeout).close()
    except OSError as exc:
        raise DataFileError(
            f"cannot reach {HOST} (no network: {exc}); download the files from {HISTDATA_PAGE}"
        ) from exc


def _downloader() -> Callable[..., str]:
    try:
        from histdata import download_hist_data
    except ImportError as exc:
        msg = "fetching HistData files needs the `histdata` extra: `pip install 'gym4real-trading[histdata]'`"
        raise DataFileError(msg) from exc
    return download_hist_data  # type: ignore[no-any-return]


def _extract(zip_path: Path, dest: Path) -> Path:
    """Extract the CSV of a HistData zip into ``dest`` and delete the zip."""
    try:
        with zipfile.ZipFile(zip_path) as zf:
            members = [n for n in zf.namelist() if n.lower().endswith(".csv")]
            if len(members) != 1:
                raise DataFileError(
                    f"`{zip_path}` holds {members}, expected one .csv (is {HOST} serving an error page?)"
                )
            target = dest / Path(members[0]).name
            tmp = target.with_suffix(".part")
            tmp.write_bytes(zf.read(members[0]))
            tmp.replace(target)
    except zipfile.BadZipFile as exc:
        raise DataFileError(f"`{zip_path}` is not a zip file ({exc}); {HOST} may have refused the download") from exc
    zip_path.unlink()
    return target


def planned_files(years: Sequence[int], kind: str = "tick", pair: str = "EURUSD") -> list[tuple[int, int | None, str]]:
    """(year, month or None, CSV name) of every file to download."""
    if kind not in ("tick", "m1"):
        raise DataFileError(f"`kind` must be `tick` or `m1`, not `{kind}`")
    if kind == "tick":
        return [(y, m, f"DAT_ASCII_{pair}_T_{y}{m:02d}.csv") for y in sorted(set(years)) for m in range(1, 13)]
    return [(y, None, f"DAT_ASCII_{pair}_M1_{y}.csv") for y in sorted(set(years))]


def fetch(
    years: Sequence[int],
    kind: str = "tick",
    pair: str = "EURUSD",
    dest: str | Path | None = None,
    timeout: float = 10.0,
    downloader: Callable[..., Any] | None = None,
) -> list[Path]:
    """Download HistData ASCII files of ``years`` (tick: 12 monthly files per year; m1: one per year).

    Args:
        years: Calendar years.
        kind: ``tick`` (the paper's data) or ``m1``.
        pair: Currency pair.
        dest: Target folder (default ``<user cache>/trading/histdata``).
        timeout: Seconds to wait for the network check.
        downloader: Replacement of ``histdata.download_hist_data`` (tests).

    Returns:
        The CSV paths, one per file, already present or downloaded.

    Raises:
        DataFileError: No network, downloads off, the extra missing, or a download that is not a zip.
    """
    if not years:
        raise DataFileError("give the years to fetch, e.g. `--years 2019 2020 2021 2022`")
    plan = planned_files(years, kind, pair)
    folder = Path(dest).expanduser() if dest else default_dest()
    todo = [item for item in plan if not (folder / item[2]).is_file()]
    if todo:
        if downloader is None:
            _check_network(timeout)
            downloader = _downloader()
        folder.mkdir(parents=True, exist_ok=True)
        for year, month, name in todo:
            print(f"fetching {name} ...", flush=True)
            zip_name = downloader(
                year=str(year),
                month=month,
                pair=pair.lower(),
                time_frame="T" if kind == "tick" else "M1",
                platform="ASCII",
                output_directory=str(folder),
                verbose=False,
            )
            _extract(Path(zip_name), folder)
    return [folder / name for _, _, name in plan]


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: fetch HistData files; errors are one line and exit status 2."""
    p = argparse.ArgumentParser(prog="python -m gym4real.trading.fetch", description=__doc__.splitlines()[0])
    p.add_argument("--years", type=int, nargs="+", required=True)
    p.add_argument("--kind", choices=["tick", "m1"], default="tick")
    p.add_argument("--pair", default="EURUSD")
    p.add_argument("--dest", default=None, help="target folder (default: <user cache>/trading/histdata)")
    args = p.parse_args(argv)
    try:
        paths = fetch(args.years, args.kind, args.pair, args.dest)
    except Gym4RealError as exc:
        print(f"gym4real: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    print(f"{len(paths)} HistData files in {paths[0].parent}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
