from __future__ import annotations

import datetime as dt
import os
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gym4real.core.errors import DataFileError
from gym4real.trading import TradingEnv, features, fetch, processing, quotes
from gym4real.trading.config import CsvColumns, SourceSection

DATA = Path(os.environ["GYM4REAL_DATA_DIR"]) / "trading"
GAP_DAY, FULL_DAYS = "20220104", ("20220103", "20220105", "20220705")


def price(day: str, minute: int) -> float:
    """A known, varying bid for a minute of the day."""
    return 1.1 + 0.0001 * ((minute * 7 + int(day[-2:]) * 13) % 50)


def tick_lines(day: str, skip: range = range(0)) -> list[str]:
    """One tick per minute (at :30.123) from 07:50 to 18:09, except the minutes in ``skip``."""
    lines = []
    for minute in range(7 * 60 + 50, 18 * 60 + 10):
        if minute in skip:
            continue
        bid = price(day, minute)
        lines.append(f"{day} {minute // 60:02d}{minute % 60:02d}30123,{bid:.6f},{bid + 0.0002:.6f},0")
    return lines


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    processing._memo.clear()
    features._memo.clear()
    return tmp_path / "cache"


@pytest.fixture
def tick_dir(tmp_path: Path) -> Path:
    """The 12 monthly HistData tick files of 2022, in the exact format."""
    folder = tmp_path / "histdata"
    folder.mkdir()
    jan = tick_lines("20220103", skip=range(9 * 60, 9 * 60 + 3))  # 3-minute gap: forward-filled
    jan.insert(0, "20220103 080010000,1.000000,1.000200,0")  # an earlier tick of the 08:00 minute
    jan += tick_lines(GAP_DAY, skip=range(12 * 60, 12 * 60 + 10))  # 10-minute gap > ffill_limit 5
    jan += tick_lines("20220105")
    for month in range(1, 13):
        day = 30 if month == 12 else 6  # a quote on the last weekday of the year: the files cover the split
        lines = {1: jan, 7: tick_lines("20220705")}.get(month, [f"2022{month:02d}{day:02d} 030000000,1.1,1.1002,0"])
        if month == 3:  # 02:30 of 13 March 2022 does not exist in US/Eastern; HistData has no DST
            lines = ["20220313 023000000,1.100000,1.100200,0", *lines]
        (folder / f"DAT_ASCII_EURUSD_T_2022{month:02d}.csv").write_text("\n".join(lines) + "\n")
    # another CSV in the folder (the reference's cache file) must not be taken for a HistData file
    (folder / "dataset_1_min_[2022].csv").write_text("garbage\n")
    return folder


def paper_env(folder: Path, kind: str = "histdata_tick", **kw: object) -> TradingEnv:
    years = {"years": [2022]}
    return TradingEnv(
        preset="paper_train",
        source={"path": str(folder), "kind": kind},
        splits={"train": years, "validation": years, "test": years},
        **kw,
    )


def test_tick_parser_reads_the_exact_format(tmp_path: Path) -> None:
    f = tmp_path / "DAT_ASCII_EURUSD_T_202203.csv"
    f.write_text("20220313 023000000,1.100000,1.100200,0\n20220103 080000123,1.130420,1.130440,0\n")
    q = quotes.read_histdata_tick(f)
    assert list(q.time) == [np.datetime64("2022-01-03T08:00:00.123", "ns"), np.datetime64("2022-03-13T02:30", "ns")]
    np.testing.assert_allclose(q.mid, [1.13043, 1.1001])
    # the same instant from a UTC source lands 5 hours earlier in market time, all year (no DST)
    utc = quotes.read_histdata_tick(f, utc_offset_hours=0)
    assert utc.time[1] == np.datetime64("2022-03-12T21:30", "ns")


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("20220103 080001000,1.130420,1.130440,0,7", "Expected 4 fields in line 2"),
        ("20220103 08000x000,1.130420,1.130440,0", "malformed line 2"),
        ("20220103 080001000,1.130420", "malformed line 2"),
        ("20220103 080001000,-1.1,1.130440,0", "malformed line 2"),
    ],
)
def test_tick_parser_rejects_a_malformed_line(tmp_path: Path, line: str, match: str) -> None:
    f = tmp_path / "DAT_ASCII_EURUSD_T_202201.csv"
    f.write_text(f"20220103 080000123,1.130420,1.130440,0\n{line}\n20220103 080002000,1.1,1.1002,0\n")
    with pytest.raises(DataFileError, match=match) as err:
        quotes.read_histdata_tick(f)
    assert f.name in str(err.value) and "YYYYMMDD HHMMSSfff,bid,ask,volume" in str(err.value)


def test_m1_parser_and_processing(tmp_path: Path, cache: Path) -> None:
    f = tmp_path / "DAT_ASCII_EURUSD_M1_2022.csv"
    lines = []
    for day, skip in (("20220103", range(0)), ("20220104", range(10 * 60, 10 * 60 + 6)), ("20220705", range(0))):
        for minute in range(8 * 60, 18 * 60):
            if minute not in skip:
                c = price(day, minute)
                lines.append(f"{day} {minute // 60:02d}{minute % 60:02d}00;{c};{c + 0.001};{c - 0.001};{c:.6f};0")
    f.write_text("\n".join(lines) + "\n")
    q = quotes.read_histdata_m1(f)
    assert len(q) == 3 * 600 - 6
    assert q.time[0] == np.datetime64("2022-01-03T08:00", "ns") and np.isclose(q.mid[0], price("20220103", 480))
    # 20220705 08:00 stays 08:00: timestamps are EST without daylight saving
    assert np.datetime64("2022-07-05T08:00", "ns") in q.time
    proc = processing.process(q, processing.Processing(bar_minutes=1, ffill_limit=5))
    assert proc.kept == [dt.date(2022, 1, 3), dt.date(2022, 7, 5)]
    assert proc.dropped[dt.date(2022, 1, 4)] == "gap of 6 min, longer than ffill_limit (5 min)"
    assert processing.drop_summary(proc.dropped)["gap longer than ffill_limit"] == 1
    assert all("no quotes" in r for d, r in proc.dropped.items() if d != dt.date(2022, 1, 4))
    # a longer limit keeps the day
    assert dt.date(2022, 1, 4) in processing.process(q, processing.Processing(ffill_limit=6)).kept
    bad = tmp_path / "DAT_ASCII_EURUSD_M1_2023.csv"
    bad.write_text(lines[0] + "\n" + lines[1].replace(";", ",") + "\n")
    with pytest.raises(DataFileError, match=r"malformed line 2 .*YYYYMMDD HHMMSS;open;high;low;close;volume"):
        quotes.read_histdata_m1(bad)


def test_env_on_histdata_tick_files(tick_dir: Path, cache: Path) -> None:
    env = paper_env(tick_dir)
    assert [d.isoformat() for d in env.days] == ["2022-01-03", "2022-01-05", "2022-07-05"]
    report = env.data_report()
    assert report["dropped_days"]["2022-01-04"] == "gap of 10 min, longer than ffill_limit (5 min)"
    assert report["reasons"]["gap longer than ffill_limit"] == 1
    assert env.observation_space.shape == (63,)
    assert env.n_steps == 119
    _obs, info = env.reset(options={"day": "2022-01-03"})
    # last tick of the 08:00 minute, not the first; mid = (bid + ask) / 2
    assert np.isclose(info["mid_price"], price("20220103", 480) + 0.0001)
    assert info["timestamp"] == np.datetime64("2022-01-03T08:00")
    # the forward-filled 09:00-09:02 minutes hold the 08:59 price
    mid = env.data.mid[0]
    assert mid[60] == mid[61] == mid[62] == mid[59]
    _, info = env.reset(options={"day": "2022-07-05"})
    assert info["timestamp"] == np.datetime64("2022-07-05T08:00")
    assert np.isclose(info["mid_price"], price("20220705", 480) + 0.0001)
    n = 0
    while True:
        n += 1
        *_, terminated, truncated, info = env.step(2)
        if terminated or truncated:
            break
    assert n == 119 and info["timestamp"] == np.datetime64("2022-07-05T17:55")
    assert paper_env(tick_dir, fidelity="upstream").n_steps == 118
    assert paper_env(tick_dir, fidelity="upstream", persistence=1).n_steps == 598
    assert paper_env(tick_dir, persistence=1).n_steps == 599


def test_upstream_fills_across_sessions(tmp_path: Path, cache: Path) -> None:
    folder = tmp_path / "m1"
    folder.mkdir()
    lines = []
    for day, start in (("20220103", 7 * 60), ("20220104", 8 * 60 + 3)):  # the 2nd day opens 3 minutes late
        for minute in range(start, 18 * 60):
            lines.append(f"{day} {minute // 60:02d}{minute % 60:02d}00;1;1;1;{price(day, minute):.6f};0")
    lines.append("20221230 030000;1;1;1;1.1;0")  # the last weekday of the year: the file covers the split
    (folder / "DAT_ASCII_EURUSD_M1_2022.csv").write_text("\n".join(lines) + "\n")
    up = paper_env(folder, fidelity="upstream", kind="histdata_m1")
    fixed = paper_env(folder, kind="histdata_m1")
    # the reference fills 08:00-08:02 of the 4th with the 17:59 price of the 3rd and keeps the day
    assert [d.isoformat() for d in up.days] == ["2022-01-03", "2022-01-04"]
    assert up.data.mid[1, 0] == up.data.mid[0, -1]
    # corrected: the fill does not cross the night (no quote before 08:03 on the 4th): dropped
    assert [d.isoformat() for d in fixed.days] == ["2022-01-03"]
    assert fixed.data_report()["dropped_days"]["2022-01-04"].startswith("gap of 3 min")
    # corrected changes at 08:00 use the 07:xx quotes; upstream's first change of the 4th spans the night
    p = [price("20220103", m) for m in (7 * 60 + 59, 8 * 60)]
    assert np.isclose(fixed.data.deltas[0, 0, 0], p[1] / p[0] - 1)
    assert np.isclose(up.data.deltas[1, 0, 0], 0.0)  # 08:00 filled with the 17:59 price: no change


def test_missing_histdata_files_say_where_and_how(tmp_path: Path, cache: Path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "DAT_ASCII_EURUSD_T_202201.csv").write_text("20220103 080000123,1.1,1.1002,0\n")
    with pytest.raises(DataFileError, match=r"missing 11 HistData file\(s\).*DAT_ASCII_EURUSD_T_202202.csv"):
        quotes.histdata_files(empty, "histdata_tick", "EURUSD", [2022])
    with pytest.raises(DataFileError) as err:
        TradingEnv(preset="paper_test", data_dir=str(tmp_path / "nowhere"))
    msg = str(err.value)
    assert "looked in" in msg and "nowhere" in msg and "python -m gym4real.trading.fetch --years 2022" in msg
    assert "histdata.com" in msg


def test_hourly_files_through_the_generic_loader() -> None:
    cols = CsvColumns(timestamp="Time", timestamp_format="%d.%m.%Y %H:%M:%S.%f", price="Close")
    q = quotes.read_csv_quotes(DATA / "eurusd_1h_ask_2017.csv", cols, utc_offset_hours=0)
    raw = pd.read_csv(DATA / "eurusd_1h_ask_2017.csv")
    assert len(q) == len(raw) == 6225
    assert q.time[0] == np.datetime64("2017-01-01T17:00", "ns")  # 22:00 UTC = 17:00 EST, Sunday's open
    np.testing.assert_array_equal(q.mid, raw["Close"].to_numpy())
    proc = processing.process(q, processing.Processing(bar_minutes=60, ffill_limit=0, trading_close=16))
    assert len(proc.kept) > 240
    assert proc.dropped[dt.date(2017, 12, 25)].startswith("no quotes")
    day = proc.day_index(dt.date(2017, 3, 1)) * 24
    sel = raw["Time"].str.startswith("01.03.2017")
    np.testing.assert_array_equal(proc.mid[day + 8 : day + 16], raw.loc[sel, "Close"].to_numpy()[13:21])
    bt = quotes.read_csv_quotes(DATA / "eurusd_1h_2017-2018.csv", CsvColumns(timestamp=0, price="Close"), 0)
    assert len(bt) == 5000 and bt.time[-1] == np.datetime64("2018-02-07T10:00", "ns")
    # the two files agree within a pip where they overlap (the same hours in the same time zone)
    both = pd.Series(q.mid, q.time).align(pd.Series(bt.mid, bt.time), join="inner")
    assert len(both[0]) > 4000 and np.abs(both[0] - both[1]).max() < 5e-4


def test_hourly_data_at_a_1_minute_bar_is_refused_with_the_reason(cache: Path) -> None:
    with pytest.raises(DataFileError, match=r"60 min apart, coarser than `bar_minutes` \(1\)"):
        TradingEnv(bar_minutes=1, persistence=5, offset=1, ffill_limit=5)


def test_csv_mapping_errors(tmp_path: Path) -> None:
    f = tmp_path / "q.csv"
    f.write_text("when,b,a\n2022-01-03 08:00:00,1.1,1.1002\n2022-01-03 08:01:00,x,1.1\n")
    with pytest.raises(DataFileError, match=r"no column `bid`.*\['when', 'b', 'a'\]"):
        quotes.read_csv_quotes(f, CsvColumns(timestamp="when", bid="bid", ask="a"))
    with pytest.raises(DataFileError, match="malformed line 3"):
        quotes.read_csv_quotes(f, CsvColumns(timestamp="when", bid="b", ask="a"))
    with pytest.raises(ValueError, match="either both"):
        CsvColumns(timestamp=0, bid="b")


def test_parquet_cache_is_keyed_by_hashes_and_parameters(
    tick_dir: Path, cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    first = paper_env(tick_dir)
    files = list((cache / "trading" / "processed").glob("*.parquet"))
    assert len(files) == 1
    processing._memo.clear()
    features._memo.clear()

    def boom(*args: object) -> None:
        raise AssertionError("the source files were read again")

    monkeypatch.setattr(processing, "read_source", boom)
    again = paper_env(tick_dir)  # from the parquet cache
    np.testing.assert_array_equal(first.data.mid, again.data.mid)
    assert again.data.dropped == first.data.dropped
    with pytest.raises(AssertionError, match="read again"):
        paper_env(tick_dir, ffill_limit=10)  # another processing parameter: another key
    path = tick_dir / "DAT_ASCII_EURUSD_T_202207.csv"
    path.write_text(path.read_text().replace("1.1", "1.2", 1))
    os.utime(path, ns=(1, 1))
    with pytest.raises(AssertionError, match="read again"):
        paper_env(tick_dir)  # another file content: another hash


def test_fetch_offline_is_one_clear_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert fetch.main(["--years", "2019", "--dest", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith("gym4real: error: cannot download from www.histdata.com")


def test_fetch_extracts_the_histdata_zips(tmp_path: Path) -> None:
    calls = []

    def fake(
        year: str, month: int | None, pair: str, time_frame: str, platform: str, output_directory: str, verbose: bool
    ) -> str:
        calls.append((year, month))
        name = f"DAT_{platform}_{pair.upper()}_{time_frame}_{year}{month:02d}"
        zpath = Path(output_directory) / f"{name}.zip"
        with zipfile.ZipFile(zpath, "w") as zf:
            zf.writestr(f"{name}.csv", f"{year}{month:02d}03 080000123,1.1,1.1002,0\n")
            zf.writestr(f"{name}.txt", "status")
        return str(zpath)

    (tmp_path / "DAT_ASCII_EURUSD_T_201901.csv").write_text("already here\n")
    paths = fetch.fetch([2019], dest=tmp_path, downloader=fake)
    assert len(paths) == 12 and all(p.is_file() for p in paths)
    assert calls == [("2019", m) for m in range(2, 13)]  # January was already there
    assert not list(tmp_path.glob("*.zip"))
    assert quotes.histdata_files(tmp_path, "histdata_tick", "EURUSD", [2019]) == paths
    assert fetch.planned_files([2020], "m1") == [(2020, None, "DAT_ASCII_EURUSD_M1_2020.csv")]


def test_source_section_validation() -> None:
    with pytest.raises(ValueError, match="needs `dataset` or `path`"):
        SourceSection(kind="csv")
    with pytest.raises(ValueError, match="for `csv` sources"):
        SourceSection(kind="histdata_tick", dataset="trading/eurusd_1h_ask_2017")
