from __future__ import annotations

import calendar
import os
from pathlib import Path

import numpy as np
import pytest

from gym4real.core.datasets import resolve
from gym4real.core.errors import DataFileError
from gym4real.dam import DamEnv
from gym4real.dam.data import calendar_days, read_daily_column, read_yearly
from gym4real.dam.evaluation import TEST_YEARS

HEADER = "year," + ",".join(str(i) for i in range(366))


def write(tmp_path: Path, rows: list[str], name: str = "x.csv") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(rows) + "\n")
    return path


def year_row(year: int, n: int, value: float = 1.0) -> str:
    return f"{year}," + ",".join([str(value)] * n + [""] * (366 - n))


def test_the_splits_hold_the_papers_years() -> None:
    train = read_yearly(resolve("dam/demand/train"), "demand")
    test = read_yearly(resolve("dam/demand/test"), "demand")
    assert len(train.years) == 52 and test.years == TEST_YEARS
    assert train.years[:4] == (1985, 1959, 1997, 2008)
    assert sorted(train.years + test.years) == list(range(1946, 2011))  # 65 years, each once
    for table in (train, test):  # 366 values exactly in the calendar's leap years
        assert all((len(v) == 366) == calendar.isleap(y) for y, v in table.values.items())
    assert sum(len(v) == 366 for v in train.values.values()) == 14
    assert sum(len(v) == 366 for v in test.values.values()) == 2


def test_value_ranges_of_the_spec() -> None:
    demand = read_yearly(resolve("dam/demand/train"), "demand")
    inflow = read_yearly(resolve("dam/inflow/test"), "inflow")
    values = np.concatenate([np.array(v) for v in demand.values.values()])
    assert values.min() == 18.0 and values.max() == 917.7
    assert values.mean() == pytest.approx(158.0, abs=0.05)
    values = np.concatenate([np.array(v) for v in inflow.values.values()])
    assert values.min() == 9.6 and values.max() == 1164.6
    mef = read_daily_column(resolve("dam/mef"), "MEF", "MEF")
    assert mef == (5.0,) * 365


def test_leap_years_drop_29_february_or_keep_the_reference_days() -> None:
    levels = read_yearly(resolve("dam/level/test"), "level")
    raw = levels.values[1996]
    dropped = calendar_days(levels, 1996, drop_feb29=True)
    kept = calendar_days(levels, 1996, drop_feb29=False)
    assert len(dropped) == len(kept) == 365
    assert dropped[:59] == list(raw[:59]) and dropped[59:] == list(raw[60:])  # 1 March follows 28 February
    assert kept == list(raw[:365])  # the reference: 31 December is dropped
    assert calendar_days(levels, 1950, True) == list(levels.values[1950])


def test_truncated_file_names_the_file_and_the_line(tmp_path: Path) -> None:
    full = write(tmp_path, [HEADER, year_row(2001, 365), year_row(2002, 365)])
    text = full.read_text()
    full.write_text(text[: len(text) - 700])  # cut inside the last row
    with pytest.raises(DataFileError, match=r"line 3 of inflow file `.*x\.csv` has \d+ fields, expected 367"):
        read_yearly(full, "inflow")


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ([], "is empty"),
        (["day,0,1"], "header"),
        ([HEADER], "no year rows"),
        ([HEADER, year_row(2001, 365).replace("1.0", "abc", 1)], "`abc`, not a number"),
        ([HEADER, year_row(2001, 300)], "300 values, expected 365 or 366"),
        ([HEADER, year_row(2001, 365), year_row(2001, 365)], "year 2001 twice"),
        ([HEADER, "2001,1.0,," + ",".join(["1.0"] * 364)], "gap"),
        ([HEADER, year_row(2001, 365, value=-3.0)], "outside the accepted range"),
        ([HEADER, year_row(2001, 365, value=5000.0)], "raise `max_inflow`"),
        ([HEADER, "x199," + year_row(2001, 365).split(",", 1)[1]], "not an integer"),
    ],
)
def test_malformed_files_raise_clear_errors(tmp_path: Path, rows: list[str], message: str) -> None:
    path = write(tmp_path, rows)
    with pytest.raises(DataFileError, match=message) as err:
        read_yearly(path, "inflow", 0.0, 2000.0)
    assert "x.csv" in str(err.value)


def test_366_values_in_a_common_year_is_an_error(tmp_path: Path) -> None:
    table = read_yearly(write(tmp_path, [HEADER, year_row(2001, 366)]), "demand")
    with pytest.raises(DataFileError, match="not a leap year"):
        calendar_days(table, 2001, drop_feb29=True)
    assert len(calendar_days(table, 2001, drop_feb29=False)) == 365


def test_daily_column_files(tmp_path: Path) -> None:
    with pytest.raises(DataFileError, match="no column `MEF`"):
        read_daily_column(write(tmp_path, ["flow", *["5.0"] * 365]), "MEF", "MEF")
    with pytest.raises(DataFileError, match="expected 365 daily values"):
        read_daily_column(write(tmp_path, ["MEF", *["5.0"] * 100], "y.csv"), "MEF", "MEF")
    with pytest.raises(DataFileError, match="negative"):
        read_daily_column(write(tmp_path, ["rate", *["-1.0"] * 365], "z.csv"), "evaporation rate")


def test_env_with_a_truncated_data_file_names_it(tmp_path: Path) -> None:
    source = Path(os.environ["GYM4REAL_DATA_DIR"])
    for rel in ("dam/MEF.csv", "dam/demand/water_demand_test.csv", "dam/level/water_level_test.csv"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes((source / rel).read_bytes())
    inflow = tmp_path / "dam/inflow/water_inflow_test.csv"
    inflow.parent.mkdir(parents=True)
    inflow.write_bytes((source / "dam/inflow/water_inflow_test.csv").read_bytes()[:5000])
    with pytest.raises(DataFileError, match=r"water_inflow_test\.csv"):
        DamEnv(preset="test", data_dir=str(tmp_path))


def test_mismatched_demand_and_inflow_years(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from gym4real.dam import env as env_module

    demand = read_yearly(write(tmp_path, [HEADER, year_row(2001, 365)], "d.csv"), "demand")
    inflow = read_yearly(write(tmp_path, [HEADER, year_row(2002, 365)], "i.csv"), "inflow")
    tables = iter([demand, inflow])
    monkeypatch.setattr(env_module, "read_yearly", lambda *a, **k: next(tables))
    with pytest.raises(DataFileError, match="disagree on year 2001"):
        DamEnv(preset="test")
