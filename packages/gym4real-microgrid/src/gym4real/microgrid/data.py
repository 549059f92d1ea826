"""The exogenous series of MicrogridEnv: demand profiles, PV generation, market prices, ambient temperature.

Each file is read once per process (memoised on its path, size and modification time) and validated
against its table's schema: a missing column, a column of another table (the market file given as
demand), a non-numeric or non-finite value, a value outside the plausible range of its unit
(:data:`UNITS`: a price in EUR/MWh, a demand in kW, a temperature in °C), ask below bid, or an
irregular time step raises :class:`~gym4real.core.errors.DataFileError` naming the file, the column
and what was expected.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from gym4real.core.errors import DataFileError

DOMAIN = "microgrid"
TRAIN_DEMAND = "demand/train"
#: Where the synthetic stand-in for the training households lies under a data folder
#: (:mod:`gym4real.microgrid.standin` writes it).
STAND_IN = "microgrid/demand/profiles_train_standin.csv"
#: Households of the paper's training file (``profiles_train.csv``).
PAPER_HOUSEHOLDS = 370
#: CPU seconds of one stand-in household (:mod:`gym4real.microgrid.standin`, its days compiled): 0.42 s,
#: the median of 20 households on the 2-core development machine (``benchmarks/bench_standin.py``;
#: richardsonpy alone took 21 s). A loaded machine takes longer: a job gets a share of a core.
SECONDS_PER_HOUSEHOLD = 0.42
#: Seconds of a synthesis beside its households, measured on the same machine: starting the command (1 s),
#: loading the compiled model in each worker (1 s; compiling it takes 7 s more, the first time only) and
#: writing the CSV of the 370 households (1.3 s).
SECONDS_OVERHEAD = 4.0


class StandInWarning(UserWarning):
    """Training reads a stand-in of fewer households than the paper's training file."""


def synthesis_time(households: int = PAPER_HOUSEHOLDS, jobs: int = 1) -> str:
    """``about 3 min``: the expected time of ``gym4real data synthesize microgrid`` for ``households``."""
    seconds = SECONDS_OVERHEAD + -(-households // max(1, jobs)) * SECONDS_PER_HOUSEHOLD
    return f"about {seconds:.0f} s" if seconds < 120 else f"about {seconds / 60:.0f} min"


def _synthesize_command() -> str:
    return (
        f"`gym4real data synthesize microgrid` ({synthesis_time()} for the {PAPER_HOUSEHOLDS} households on one "
        "core, less on more; `pip install richardsonpy 'gym4real-microgrid[fast]'` first)"
    )


_warned: set[Path] = set()


def warn_if_fewer_households(path: Path) -> None:
    """Warn once per file when the stand-in that training reads holds fewer households than the paper's file."""
    if path in _warned:
        return
    _warned.add(path)
    with path.open(encoding="utf-8") as f:
        count = sum(1 for name in f.readline().strip().split(",") if name != "delta_time")
    if count < PAPER_HOUSEHOLDS:
        warnings.warn(
            f"training on {count} stand-in households (`{path}`), fewer than the {PAPER_HOUSEHOLDS} of the paper's "
            f"training file: results are not comparable with a full stand-in; {_synthesize_command()} writes all "
            f"{PAPER_HOUSEHOLDS}",
            StandInWarning,
            stacklevel=3,
        )


#: Unit and plausible range ``(low, high, unit)`` of every value column (demand: each household column).
UNITS: dict[str, tuple[float, float, str]] = {
    "demand": (0.0, 100_000.0, "W per household"),
    "PV": (0.0, 100_000_000.0, "W"),
    "ask": (0.0, 0.01, "EUR/Wh (0.01 EUR/Wh is 10,000 EUR/MWh; divide EUR/MWh by 1e6, EUR/kWh by 1e3)"),
    "bid": (0.0, 0.01, "EUR/Wh (0.01 EUR/Wh is 10,000 EUR/MWh; divide EUR/MWh by 1e6, EUR/kWh by 1e3)"),
    "temp_amb": (150.0, 350.0, "K (add 273.15 to °C)"),
}
#: Smallest peak of a demand file (W): a file whose largest household demand is lower is in kW or not demand.
MIN_DEMAND_PEAK = 10.0
#: Which table each value column belongs to (a demand file must hold none of them).
TABLE_OF = {"PV": "generation", "ask": "market", "bid": "market", "temp_amb": "ambient temperature"}


def data_path(ref: str, data_dir: str | Path | None) -> Path:
    """Locate a data file: a path ending in ``.csv`` as given, otherwise a registered ``microgrid/<ref>``."""
    if ref.endswith(".csv"):
        path = Path(ref).expanduser()
        if not path.is_file():
            problem = "is a folder, not a CSV file" if path.is_dir() else "does not exist"
            raise DataFileError(f"data file `{path}` {problem}; give the path of a `.csv` file or a registered name")
        return path
    from gym4real.core.datasets import resolve

    return resolve(f"{DOMAIN}/{ref}", data_dir)


def training_demand(data_dir: str | Path | None) -> tuple[Path, str]:
    """The training households' demand file and its source: the real one, else the synthetic stand-in.

    Returns ``(path, "real")`` when ``profiles_train.csv`` is found (and intact), else ``(path, "stand-in")``
    for the stand-in written by ``gym4real data synthesize microgrid`` (:mod:`gym4real.microgrid.standin`).

    Raises:
        DataFileError: Neither is found; the message gives both fixes (and how long the stand-in takes).
    """
    from gym4real.core.datasets import find, find_stand_in

    if find(f"{DOMAIN}/{TRAIN_DEMAND}", data_dir) is None and (copy := find_stand_in(STAND_IN, data_dir)) is not None:
        return copy.path, "stand-in"
    try:
        return data_path(TRAIN_DEMAND, data_dir), "real"
    except DataFileError as exc:
        msg = (
            f"{exc}\nThe 370 training households (`profiles_train.csv`) are published upstream but were absent "
            "from the reference snapshot. Either place the file in a data folder "
            "(`<GYM4REAL_DATA_DIR>/microgrid/demand/profiles_train.csv`), or write the synthetic stand-in "
            f"(Richardson load model calibrated to Italian households) with {_synthesize_command()}, or pass "
            '`data={"demand": "<path>.csv"}`; preset "default" or "test" runs on the 2019 data.'
        )
        raise DataFileError(msg) from exc


def _read(path: Path, columns: list[str], what: str) -> pd.DataFrame:
    try:
        frame = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        msg = f"cannot read {what} file `{path}`: {exc}"
        raise DataFileError(msg) from exc
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        msg = f"{what} file `{path}` lacks column(s) {missing}: expected {columns}, found {list(frame.columns)}"
        raise DataFileError(msg)
    if len(frame) < 2:
        msg = f"{what} file `{path}` has {len(frame)} row(s); expected a time series of at least two rows"
        raise DataFileError(msg)
    return frame


def _numeric(frame: pd.DataFrame, column: str, path: Path, what: str, unit: str | None = None) -> np.ndarray:
    """A column's values: finite numbers, within the range of ``UNITS[unit]`` (no range when ``None``)."""
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=np.float64)
    bad = ~np.isfinite(values)
    expected = "a finite number"
    if unit is not None:
        low, high, name = UNITS[unit]
        bad |= (values < low) | (values > high)
        expected = f"a number in [{low:g}, {high:g}] {name}"
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        value = frame[column].iloc[row]
        msg = f"{what} file `{path}`: column `{column}` row {row + 2} holds {value!r}; expected {expected}"
        raise DataFileError(msg)
    return values


def _check_step(frame: pd.DataFrame, path: Path, what: str, step: float) -> np.ndarray:
    times = _numeric(frame, "delta_time", path, what)
    diffs = np.diff(times)
    if not np.allclose(diffs, step):
        row = int(np.flatnonzero(~np.isclose(diffs, step))[0])
        msg = (
            f"{what} file `{path}`: `delta_time` must advance by {step:g} s per row; rows {row + 2} and "
            f"{row + 3} are {diffs[row]:g} s apart"
        )
        raise DataFileError(msg)
    return times


def _key(path: Path) -> tuple[str, int, int]:
    st = path.stat()
    return str(path.resolve()), st.st_size, st.st_mtime_ns


@functools.lru_cache(maxsize=16)
def _demand(key: tuple[str, int, int], step: float) -> tuple[tuple[str, ...], np.ndarray]:
    path = Path(key[0])
    frame = _read(path, ["delta_time"], "demand")
    _check_step(frame, path, "demand", step)
    labels = tuple(str(c) for c in frame.columns if c not in ("delta_time", "timestamp"))
    if not labels:
        msg = f"demand file `{path}` has no profile column besides `delta_time`; expected one column per household"
        raise DataFileError(msg)
    foreign = [c for c in labels if c in TABLE_OF]
    if foreign:
        msg = (
            f"demand file `{path}` has column `{foreign[0]}` of the {TABLE_OF[foreign[0]]} table; expected one column "
            "of household demand (W) per profile: does `data.demand` name the right file?"
        )
        raise DataFileError(msg)
    table = np.column_stack([_numeric(frame, c, path, "demand", "demand") for c in labels])
    if table.max() < MIN_DEMAND_PEAK:
        msg = (
            f"demand file `{path}`: the largest demand of any column is {table.max():g}; expected W, which peak above "
            f"{MIN_DEMAND_PEAK:g} W in a household (a demand in kW must be multiplied by 1000)"
        )
        raise DataFileError(msg)
    table.flags.writeable = False
    return labels, table


@functools.lru_cache(maxsize=16)
def _series(key: tuple[str, int, int], what: str, columns: tuple[str, ...], step: float) -> tuple[np.ndarray, ...]:
    path = Path(key[0])
    frame = _read(path, [*columns, "delta_time"], what)
    times = _check_step(frame, path, what, step)
    out = [_numeric(frame, c, path, what, c) for c in columns]
    for a in (*out, times):
        a.flags.writeable = False
    return (*out, times)


def read_demand(path: Path, step: float = 3600.0) -> tuple[tuple[str, ...], np.ndarray]:
    """Demand profiles (W): the column labels and an array ``[row, profile]``."""
    return _demand(_key(path), float(step))


def read_generation(path: Path, step: float = 3600.0) -> tuple[np.ndarray, np.ndarray]:
    """PV generation (W) and ``delta_time`` (s)."""
    pv, times = _series(_key(path), "generation", ("PV",), float(step))
    return pv, times


def read_market(path: Path, step: float = 3600.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Buy (``ask``) and sell (``bid``) prices (EUR/Wh) and ``delta_time`` (s)."""
    ask, bid, times = _series(_key(path), "market", ("ask", "bid"), float(step))
    if (ask < bid).any():
        row = int(np.flatnonzero(ask < bid)[0])
        msg = (
            f"market file `{path}` row {row + 2}: `ask` (buy price, {ask[row]:g}) is below `bid` (sell price, "
            f"{bid[row]:g}); expected ask >= bid: are the two columns swapped?"
        )
        raise DataFileError(msg)
    return ask, bid, times


def read_temperature(path: Path, step: float = 86400.0) -> tuple[np.ndarray, np.ndarray]:
    """Daily ambient temperature (K) and ``delta_time`` (s)."""
    temp, times = _series(_key(path), "ambient temperature", ("temp_amb",), float(step))
    return temp, times


@dataclass(frozen=True)
class World:
    """The validated series of one split, as plain Python lists for fast indexing in the step.

    Attributes:
        labels: Demand profile labels (column names).
        demand: Demand array ``[row, profile]`` (W).
        pv: PV generation per row (W).
        ask: Buy price per row (EUR/Wh).
        bid: Sell price per row (EUR/Wh).
        temp: Ambient temperature per day (K).
        times: ``delta_time`` of the generation rows (s from the first row).
        step: Seconds per row of the hourly series.
        temp_step: Seconds per row of the temperature series.
        trading_norm: ``max(max PV * max bid, max demand * max ask)`` (the reference's normaliser).
        clipping_norm: ``max(|max demand - min PV|, |max PV - min demand|)``.
    """

    labels: tuple[str, ...]
    demand: np.ndarray
    pv: list[float]
    ask: list[float]
    bid: list[float]
    temp: list[float]
    times: list[float]
    step: float
    temp_step: float
    trading_norm: float
    clipping_norm: float

    @classmethod
    def load(
        cls,
        demand: Path,
        generation: Path | None,
        market: Path | None,
        temperature: Path | None,
        step: float,
        temp_step: float,
        dummy: tuple[float, float, float, float],
    ) -> World:
        """Read and cross-check the files of a split; a missing series (None) is a constant.

        Args:
            demand: Demand file.
            generation: PV file, or None for the constant ``dummy[0]`` (W) over the hours of the market
                file, else of the demand file.
            market: Price file, or None for the constant ask and bid ``dummy[1:3]`` (EUR/Wh).
            temperature: Ambient temperature file, or None for the constant ``dummy[3]`` (K) over the days
                the hourly series span.
            step: Seconds per hourly row.
            temp_step: Seconds per temperature row.
            dummy: The constants standing in for missing files.
        """
        labels, table = read_demand(demand, step)
        gen_dummy, ask_dummy, bid_dummy, temp_dummy = dummy
        ask = bid = None
        if market is not None:
            ask, bid, _ = read_market(market, step)
        if generation is not None:
            pv, times = read_generation(generation, step)
        else:
            rows = len(ask) if ask is not None else len(table)
            pv, times = np.full(rows, gen_dummy), np.arange(rows) * step
        if ask is None or bid is None:
            ask, bid = np.full(len(pv), ask_dummy), np.full(len(pv), bid_dummy)
        if temperature is not None:
            temp, _ = read_temperature(temperature, temp_step)
        else:
            temp = np.full(int(np.ceil(len(pv) * step / temp_step)), temp_dummy)
        if len(ask) != len(pv):
            msg = (
                f"market file `{market}` has {len(ask)} rows but generation file `{generation}` has {len(pv)}; "
                "the hourly series must cover the same hours"
            )
            raise DataFileError(msg)
        if len(temp) * temp_step < len(pv) * step:
            msg = (
                f"ambient temperature file `{temperature}` covers {len(temp)} days, fewer than the "
                f"{len(pv) * step / temp_step:g} days of `{generation}`"
            )
            raise DataFileError(msg)
        max_demand, min_demand = float(table.max()), float(table.min())
        return cls(
            labels=labels,
            demand=table,
            pv=pv.tolist(),
            ask=ask.tolist(),
            bid=bid.tolist(),
            temp=temp.tolist(),
            times=times.tolist(),
            step=step,
            temp_step=temp_step,
            trading_norm=max(float(pv.max()) * float(bid.max()), max_demand * float(ask.max())),
            clipping_norm=max(abs(max_demand - float(pv.min())), abs(float(pv.max()) - min_demand)),
        )

    @functools.cached_property
    def _profiles(self) -> dict[str, list[float]]:
        return {}

    def profile(self, label: str) -> list[float]:
        """The demand profile ``label`` as a list (W per row), memoised."""
        cache = self._profiles
        if label not in cache:
            cache[label] = self.demand[:, self.labels.index(label)].tolist()
        return cache[label]
