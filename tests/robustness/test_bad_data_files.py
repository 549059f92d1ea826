"""Data files on user-supplied paths (no hash by design): bad data is a DataFileError naming the file.

Issue 12, section 5. Each test builds its bad file in ``tmp_path`` from the real data (a truncated,
rescaled or re-encoded copy) or from scratch, and checks that the error names the file, the column
or part at fault and what was expected, at construction rather than later or never.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

import gym4real
from gym4real.core.datasets import resolve
from gym4real.core.errors import DataFileError
from gym4real.microgrid.tables import read_table

LATIN1 = "# r\xe9glage\n".encode("latin-1")  # not UTF-8: 0xe9 starts a multi-byte sequence


# -- trading: the quotes must cover the split ---------------------------------------------------------

TRADING_SOURCE = {
    "kind": "csv",
    "dataset": None,
    "utc_offset_hours": 0,
    "columns": {"timestamp": "Time", "timestamp_format": "%d.%m.%Y %H:%M:%S.%f", "price": "Close"},
}


@pytest.fixture(autouse=True)
def _own_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Processed copies of the files made here go to a cache of the test's own."""
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))


def _quotes_until(tmp_path: Path, first_excluded: str) -> Path:
    """The real hourly 2017 quotes, cut before the first line starting with ``first_excluded``."""
    lines = resolve("trading/eurusd_1h_ask_2017").read_text().splitlines()
    end = next(i for i, line in enumerate(lines) if line.startswith(first_excluded))
    path = tmp_path / "eurusd_truncated.csv"
    path.write_text("\n".join(lines[:end]) + "\n")
    return path


def test_a_truncated_trading_csv_is_refused_naming_what_is_missing(tmp_path: Path) -> None:
    path = _quotes_until(tmp_path, "03.07.2017")  # the train split runs to 2017-08-31
    source = {**TRADING_SOURCE, "path": str(path)}
    with pytest.raises(DataFileError) as exc:
        gym4real.make("gym4real/trading-v0", source=source, split="train")
    message = str(exc.value)
    assert "eurusd_truncated.csv" in message and "split `train` runs 2017-01-01 .. 2017-08-31" in message
    assert "44 weekdays (2017-07-03 .. 2017-08-31) have no quotes" in message and "splits.train.end" in message
    short = gym4real.make("gym4real/trading-v0", source=source, splits={"train": {"end": "2017-06-30"}})
    assert str(short.unwrapped.days[-1]) == "2017-06-30"  # the fix the message names works


def test_a_split_ending_on_a_holiday_weekend_is_still_covered(tmp_path: Path) -> None:
    path = _quotes_until(tmp_path, "14.04.2017")  # Good Friday: no quotes on the last weekday of the split
    source = {**TRADING_SOURCE, "path": str(path)}
    env = gym4real.make("gym4real/trading-v0", source=source, splits={"train": {"end": "2017-04-16"}})
    assert str(env.unwrapped.days[-1]) == "2017-04-13"


# -- microgrid: each table's schema (columns, units, ranges) ------------------------------------------


def _table(name: str) -> pd.DataFrame:
    return pd.read_csv(resolve(f"microgrid/{name}"))


def _write(frame: pd.DataFrame, path: Path) -> str:
    frame.to_csv(path, index=False)
    return str(path)


def test_the_market_file_given_as_demand_is_refused_naming_the_column() -> None:
    market = resolve("microgrid/market/test")  # named resolved: the data folder may be reached through a link
    with pytest.raises(DataFileError, match=rf"demand file `{re.escape(str(market.resolve()))}` has column `bid` of"):
        gym4real.make("gym4real/microgrid-v0", data={"demand": str(market)})


def _bad_tables(tmp_path: Path) -> list[tuple[str, Any, str]]:
    demand, market = _table("demand/test"), _table("market/test")
    profiles = [c for c in demand.columns if c != "delta_time"]
    kw = demand.assign(**{c: demand[c] / 1000.0 for c in profiles})
    mwh = market.assign(ask=market["ask"] * 1e6, bid=market["bid"] * 1e6)
    swapped = market.rename(columns={"ask": "bid", "bid": "ask"})
    return [
        ("demand", _write(kw, tmp_path / "demand_kw.csv"), r"demand_kw\.csv`: the largest demand .* expected W"),
        ("market", _write(mwh, tmp_path / "market_mwh.csv"), r"market_mwh\.csv`: column `ask` row 2 .*EUR/Wh"),
        ("market", _write(swapped, tmp_path / "swapped.csv"), r"swapped\.csv` row 2: `ask` .* below `bid`"),
    ]


def test_microgrid_tables_in_the_wrong_unit_are_refused_naming_file_and_column(tmp_path: Path) -> None:
    for key, path, pattern in _bad_tables(tmp_path):
        with pytest.raises(DataFileError, match=pattern):
            gym4real.make("gym4real/microgrid-v0", preset="test", data={key: path})


@pytest.mark.parametrize(
    ("column", "change", "pattern"),
    [
        ("temp", lambda t: t + 273.15, r"column `temp` holds 273\.15; expected a temperature in °C"),
        ("soc", lambda s: s * 100.0, r"column `soc` holds 5; expected a state of charge in \[0, 1\]"),
        ("r0", lambda r: -r, r"column `r0` holds -0\.214.*; expected a positive parameter"),
    ],
)
def test_lookup_tables_out_of_their_range_name_the_file_and_column(
    tmp_path: Path, column: str, change: Any, pattern: str
) -> None:
    table = pd.read_csv(resolve("microgrid/battery/r0"))
    table[column] = change(table[column])
    path = Path(_write(table, tmp_path / "r0_bad.csv"))
    with pytest.raises(DataFileError, match=rf"`{re.escape(str(path))}` line \d+: {pattern}"):
        read_table(path, ("temp", "soc"), "r0")


def test_non_utf8_battery_yaml_and_lookup_table_are_data_file_errors(tmp_path: Path) -> None:
    pack = tmp_path / "pack.yaml"
    pack.write_bytes(resolve("microgrid/battery/pack").read_bytes() + LATIN1)
    with pytest.raises(DataFileError, match=rf"battery configuration `{re.escape(str(pack))}` is not UTF-8 text"):
        gym4real.make("gym4real/microgrid-v0", battery={"pack": str(pack)})
    table = tmp_path / "r0.csv"
    table.write_bytes(resolve("microgrid/battery/r0").read_bytes() + LATIN1)
    with pytest.raises(DataFileError, match=rf"lookup table `{re.escape(str(table))}` is not UTF-8 text"):
        read_table(table, ("temp", "soc"), "r0")


def test_a_folder_given_as_a_data_file_is_called_a_folder(tmp_path: Path) -> None:
    folder = tmp_path / "series.csv"
    folder.mkdir()
    with pytest.raises(DataFileError, match="is a folder, not a CSV file"):
        gym4real.make("gym4real/microgrid-v0", data={"demand": str(folder)})
    source = {**TRADING_SOURCE, "path": str(folder)}
    with pytest.raises(DataFileError, match="is a folder, not a CSV file"):
        gym4real.make("gym4real/trading-v0", source=source)


# -- wds ---------------------------------------------------------------------------------------------


def test_a_folder_given_as_wds_network_is_called_a_folder(tmp_path: Path) -> None:
    with pytest.raises(DataFileError, match=rf"network file `{re.escape(str(tmp_path))}` is a folder, not a file"):
        gym4real.make("gym4real/wds-v0", network=str(tmp_path))


@pytest.mark.parametrize(
    ("inserted", "problem"),
    [
        (b"\xff\x00", r"is not UTF-8 text \(line {line}, byte {column}: byte 0xff"),
        (b"\x00", r"is not text \(line {line}, column {column}: control character U\+0000\)"),
    ],
    ids=["ff-00", "nul"],
)
def test_binary_bytes_in_a_wds_network_field_are_refused_naming_the_line(
    tmp_path: Path, inserted: bytes, problem: str
) -> None:
    """EPANET reads `3657.6<ff 00>001` as 3657.6 and simulates another network: the file is refused instead."""
    source = resolve("wds/anytown").read_bytes()
    field = source.index(b"3657.6001")
    line = source.count(b"\n", 0, field) + 1
    column = field - source.rfind(b"\n", 0, field) + len(b"3657.6")
    network = tmp_path / "anytown.inp"
    network.write_bytes(source[:field] + b"3657.6" + inserted + source[field + len(b"3657.6") :])
    pattern = rf"network file `{re.escape(str(network))}` " + problem.format(line=line, column=column)
    with pytest.raises(DataFileError, match=pattern):
        gym4real.make("gym4real/wds-v0", network=str(network))


def test_a_wds_pump_with_neither_head_curve_nor_power_is_refused_at_make_naming_it(tmp_path: Path) -> None:
    """EPANET opens such a network and fails at the first solve (Error 110): it is refused when made instead."""
    lines = resolve("wds/anytown").read_text().splitlines(keepends=True)
    (row,) = [i for i, line in enumerate(lines) if line.split()[:1] == ["P79"]]
    assert "HEAD H1" in lines[row]
    lines[row] = lines[row].replace("HEAD H1", "")
    network = tmp_path / "no_curve.inp"
    network.write_text("".join(lines))
    with pytest.raises(DataFileError, match=rf"`{re.escape(str(network))}`: pump\(s\) `P79` in \[PUMPS\]") as err:
        gym4real.make("gym4real/wds-v0", network=str(network))
    assert "P78" not in str(err.value) and "HEAD <curve id>" in str(err.value)


@pytest.mark.parametrize(
    ("cut", "missing"),
    [
        (lambda text: text[: text.index("[OPTIONS]")], "[OPTIONS], [END]"),  # a copy cut before its options
        (lambda text: text[: text.index("[END]")], "[END]"),  # cut after its last section
        (lambda text: re.sub(r"\[OPTIONS\].*?(?=\[COORDINATES\])", "", text, flags=re.S), "[OPTIONS]"),
    ],
    ids=["cut-before-options", "no-end", "no-options-section"],
)
def test_a_wds_network_cut_short_is_refused_naming_the_missing_sections(tmp_path: Path, cut: Any, missing: str) -> None:
    """EPANET fills sections it did not read with defaults (GPM, other pressure limits): refused instead."""
    network = tmp_path / "short.inp"
    network.write_text(cut(resolve("wds/anytown").read_text()))
    with pytest.raises(DataFileError, match=rf"`{re.escape(str(network))}` has no {re.escape(missing)} section"):
        gym4real.make("gym4real/wds-v0", network=str(network))


def test_a_non_utf8_wds_catalogue_is_a_data_file_error(tmp_path: Path) -> None:
    from gym4real.wds.demand import _read_catalogue

    catalogue = tmp_path / "anytown_demands.yaml"
    catalogue.write_bytes(resolve("wds/demand/catalogue").read_bytes() + LATIN1)
    with pytest.raises(DataFileError, match=rf"demand catalogue `{re.escape(str(catalogue))}` is not UTF-8 text"):
        _read_catalogue(catalogue)


# -- robofeeder ---------------------------------------------------------------------------------------


def _classifier(path: Path) -> Path:
    """An ONNX image classifier: float (1, 3, 32, 32) in, (1, 10) scores out, not a detector."""
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper

    weights = onnx.numpy_helper.from_array(np.zeros((3 * 32 * 32, 10), np.float32), "w")
    graph = helper.make_graph(
        [
            helper.make_node("Flatten", ["image"], ["flat"]),
            helper.make_node("MatMul", ["flat", "w"], ["logits"]),
        ],
        "classifier",
        [helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, 32, 32])],
        [helper.make_tensor_value_info("logits", TensorProto.FLOAT, [1, 10])],
        [weights],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, str(path))
    return path


def test_an_onnx_model_of_the_wrong_kind_is_refused_at_construction(tmp_path: Path) -> None:
    path = _classifier(tmp_path / "classifier.onnx")
    with pytest.raises(DataFileError) as exc:
        gym4real.make("gym4real/robofeeder-picking-v0", preset="test", detector=str(path))
    message = str(exc.value)
    assert f"ONNX detector `{path}` is not an object detector" in message
    assert "its input is `image` tensor(float) [1, 3, 32, 32]; expected one tensor(uint8)" in message
    assert "its box output `logits` is tensor(float) [1, 10]" in message and 'detector="classical"' in message


def test_an_empty_mesh_is_named_not_blamed_on_the_mjcf(tmp_path: Path) -> None:
    from gym4real.robofeeder import scene

    paths = scene.model_paths(None)
    for rel in [r for r in paths if r.endswith(("link_2.stl", "object_collision_3.obj"))]:
        empty = tmp_path / Path(rel).name
        empty.write_bytes(b"")
        broken = {**paths, rel: empty}
        with pytest.raises(DataFileError) as exc:
            scene._compiled(tuple(sorted(broken.items())), 1)
        assert f"mesh file `{empty}` (`{rel}`) is empty" in str(exc.value)
        assert "MJCF" not in str(exc.value)
