"""The trading processed-price cache (parquet + hash memo) is verified against its source, or rebuilt.

The reference for every check is the grid processed straight from the source file, without any cache.
"""

from __future__ import annotations

import datetime as dt
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gym4real.trading")
pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from gym4real.core import datasets  # noqa: E402
from gym4real.trading import processing  # noqa: E402
from gym4real.trading.config import CsvColumns, SourceSection  # noqa: E402

PARAMS = processing.Processing(bar_minutes=60, ffill_limit=0, trading_open=8, trading_close=16)
GAP = (dt.date(2022, 1, 5), 12)  # the hour left out of the file: with ffill_limit 0 that day is dropped


@pytest.fixture
def source(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> SourceSection:
    """An hourly price CSV (market time) of the first week of January 2022, one hour missing; an empty cache."""
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    processing._memo.clear()
    lines = ["time,price"]
    for day in range(3, 8):
        for hour in range(24):
            if (dt.date(2022, 1, day), hour) != GAP:
                lines.append(f"2022-01-{day:02d} {hour:02d}:00:00,{1.1 + 0.01 * day + 0.0001 * hour:.4f}")
    path = tmp_path / "quotes.csv"
    path.write_text("\n".join(lines) + "\n")
    return SourceSection(kind="csv", path=str(path), utc_offset_hours=-5, columns=CsvColumns(price="price"))


def load(source: SourceSection, params: processing.Processing = PARAMS) -> processing.Processed:
    """Load through the caches, as a new process would (the in-process memo cleared)."""
    processing._memo.clear()
    return processing.load(source, [2022], params, None)


def uncached(source: SourceSection, params: processing.Processing = PARAMS) -> processing.Processed:
    assert source.path is not None
    return processing.process(processing.read_source(source, [Path(source.path)]), params)


def assert_same(got: processing.Processed, want: processing.Processed) -> None:
    np.testing.assert_array_equal(got.mid, want.mid)
    assert (got.first_day, got.kept, got.dropped, got.params) == (want.first_day, want.kept, want.dropped, want.params)


def cache_file(source: SourceSection, params: processing.Processing = PARAMS) -> Path:
    return processing.cache_path(processing.cache_key(source, processing.source_files(source, [2022], None), params))


def rewrite(path: Path, mid: np.ndarray | None = None, **meta_changes: object) -> None:
    """Rewrite a cache file with other prices or metadata, as damage or an edit would."""
    table = pq.read_table(path)
    meta = json.loads(table.schema.metadata[b"gym4real"])
    meta.update(meta_changes)
    columns = {"time": table.column("time"), "mid": table.column("mid") if mid is None else mid}
    pq.write_table(pa.table(columns).replace_schema_metadata({"gym4real": json.dumps(meta)}), path)


def test_altered_prices_in_the_cache_file_are_rebuilt(source) -> None:
    want = uncached(source)
    assert_same(load(source), want)
    path = cache_file(source)
    rewrite(path, mid=want.mid + 0.5)
    assert_same(load(source), want)
    assert_same(load(source), want)  # and the file was rewritten


def test_altered_day_report_in_the_cache_file_is_rebuilt(source) -> None:
    want = uncached(source)
    assert GAP[0] in want.dropped
    load(source)
    rewrite(cache_file(source), dropped={})
    assert_same(load(source), want)


def test_a_cache_file_written_for_other_parameters_is_rebuilt(source) -> None:
    filled = processing.Processing(bar_minutes=60, ffill_limit=60, trading_open=8, trading_close=16)
    assert GAP[0] in uncached(source, filled).kept  # the two grids differ
    load(source)
    load(source, filled)
    shutil.copyfile(cache_file(source, filled), cache_file(source))
    assert_same(load(source), uncached(source))


def test_a_source_rewritten_in_place_with_the_same_size_and_time_is_processed_again(source) -> None:
    assert source.path is not None
    path = Path(source.path)
    load(source)
    st = path.stat()
    text = path.read_text()
    path.write_text(text.replace("1.1412", "1.1999"))  # same length: same size
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))  # and the same modification time
    assert path.stat().st_size == st.st_size and path.stat().st_mtime_ns == st.st_mtime_ns
    datasets._verified.clear()  # a new process: only the on-disk memo remains
    assert_same(load(source), uncached(source))
    assert (load(source).mid == 1.1999).sum() == 1


@pytest.mark.parametrize("memo", ["[]", '"text"', "{PATH: 5}", '{PATH: "abc"}', "{PATH: null}"])
def test_a_malformed_hash_memo_is_ignored(source, memo: str) -> None:
    assert source.path is not None
    memo_path = datasets.cache_dir() / "trading" / "hashes.json"
    memo_path.parent.mkdir(parents=True)
    memo_path.write_text(memo.replace("PATH", json.dumps(str(Path(source.path).resolve()))))
    assert_same(load(source), uncached(source))
