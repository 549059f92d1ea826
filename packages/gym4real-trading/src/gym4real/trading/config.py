"""Configuration of TradingEnv (reference values: ../shared/data/reference-configs/trading/world_*.yaml).

Times are in *market time*: EST without daylight saving (UTC-05:00 all year), as in HistData's files.
Durations (``bar_minutes``, ``persistence``, ``offset``, ``ffill_limit``) are in minutes.
"""

from __future__ import annotations

import datetime as dt
from typing import Literal, Self

from pydantic import Field, model_validator

from gym4real.core.config import ConfigSection, EnvConfig

#: UTC offset of market time in hours: EST without daylight saving.
MARKET_UTC_OFFSET = -5.0

SplitName = Literal["train", "validation", "test"]


class CsvColumns(ConfigSection):
    """Column mapping of a generic CSV of timestamped quotes (``source.kind: csv``).

    A column is named by its header text or by its 0-based position. Give either ``bid`` and ``ask``
    (mid = (bid + ask) / 2) or ``price`` (a single price series taken as the mid, e.g. a bar close).
    Each row is labelled by the start of its bar and its price is the last price of the bar (a bar
    close), so the row labelled 09:00 of an hourly file holds the price at 10:00.
    """

    timestamp: str | int = Field(0, description="Timestamp column (name or 0-based position).")
    timestamp_format: str | None = Field(
        None, description="strptime format of the timestamps (e.g. `%d.%m.%Y %H:%M:%S.%f`); null: ISO 8601."
    )
    bid: str | int | None = Field(None, description="Bid price column (with `ask`).")
    ask: str | int | None = Field(None, description="Ask price column (with `bid`).")
    price: str | int | None = Field(None, description="Single price column used as mid (instead of bid/ask).")
    separator: str = Field(",", description="Field separator.")
    header: bool = Field(True, description="The first line holds the column names.")

    @model_validator(mode="after")
    def _prices(self) -> Self:
        pair = self.bid is not None and self.ask is not None
        if pair == (self.price is not None) or (self.bid is None) != (self.ask is None):
            raise ValueError("give either both `bid` and `ask`, or `price`")
        return self


class SourceSection(ConfigSection):
    """Where the quotes come from."""

    kind: Literal["histdata_tick", "histdata_m1", "csv"] = Field(
        "histdata_tick",
        description="`histdata_tick` (DAT_ASCII_<PAIR>_T_YYYYMM.csv), `histdata_m1` (DAT_ASCII_<PAIR>_M1_YYYY[MM].csv) "
        "or `csv` (any CSV of quotes, with `columns`).",
    )
    dataset: str | None = Field(None, description="Registered dataset name of a CSV source (`trading/...`).")
    path: str | None = Field(
        None,
        description="CSV file (kind csv) or folder of HistData files; null: the registered dataset, or the folders "
        "`<data_dir>/trading/histdata`, `$GYM4REAL_DATA_DIR/trading/histdata` and the user cache.",
    )
    pair: str = Field("EURUSD", pattern=r"^[A-Z]{6}$", description="Currency pair of the HistData file names.")
    utc_offset_hours: float = Field(
        MARKET_UTC_OFFSET,
        ge=-12,
        le=14,
        description="UTC offset of the source's timestamps, -12 to 14 (HistData: -5, fixed; UTC files: 0).",
    )
    columns: CsvColumns = Field(
        default_factory=lambda: CsvColumns(price=4), description="Column mapping of a `csv` source."
    )

    @model_validator(mode="after")
    def _where(self) -> Self:
        if self.kind == "csv" and self.dataset is None and self.path is None:
            raise ValueError("a `csv` source needs `dataset` or `path`")
        if self.kind != "csv" and self.dataset is not None:
            raise ValueError("`dataset` is for `csv` sources; HistData sources take a folder in `path`")
        return self


class SplitSection(ConfigSection):
    """A period of trading days: whole calendar years, or a date range (inclusive)."""

    years: list[int] | None = Field(None, description="Calendar years of the split.")
    start: dt.date | None = Field(None, description="First date of the split (with `end`, instead of `years`).")
    end: dt.date | None = Field(None, description="Last date of the split, inclusive.")
    source: SourceSection | None = Field(None, description="Source of this split; null: the top-level `source`.")

    @model_validator(mode="after")
    def _period(self) -> Self:
        if (self.years is None) == (self.start is None or self.end is None):
            raise ValueError("give either `years` or both `start` and `end`")
        if self.years is not None and not self.years:
            raise ValueError("`years` must not be empty")
        if self.start is not None and self.end is not None and self.end < self.start:
            raise ValueError("`end` is before `start`")
        return self

    def bounds(self) -> tuple[dt.date, dt.date]:
        """First and last date of the split."""
        if self.years is not None:
            return dt.date(min(self.years), 1, 1), dt.date(max(self.years), 12, 31)
        assert self.start is not None and self.end is not None
        return self.start, self.end

    def contains(self, day: dt.date) -> bool:
        """Whether a date belongs to the split."""
        if self.years is not None:
            return day.year in self.years
        lo, hi = self.bounds()
        return lo <= day <= hi


class SplitsSection(ConfigSection):
    """The train / validation / test periods (the paper: 2019-2020 / 2021 / 2022)."""

    train: SplitSection = SplitSection(years=[2019, 2020])
    validation: SplitSection = SplitSection(years=[2021])
    test: SplitSection = SplitSection(years=[2022])


class FixesSection(ConfigSection):
    """Individual switches of the reference defects that change numbers; null follows `fidelity`.

    ``true`` applies the fix, ``false`` keeps the reference behaviour.
    """

    close_fee_on_new_position: bool | None = Field(
        None,
        description="Forced close at the end of the day charges the position just taken (reference: the previous one).",
    )
    full_session: bool | None = Field(
        None,
        description="Decide until the last full holding interval of the session (reference: stops 2 intervals early).",
    )
    continuous_features: bool | None = Field(
        None,
        description="Returns and forward fill on the continuous quote series (reference: on the concatenated session "
        "rows, so returns and fills cross nights, weekends and removed days).",
    )
    truncate_at_close: bool | None = Field(
        None, description="The close is a time limit: truncated only (reference: terminated and truncated)."
    )
    calendar_encoding: bool | None = Field(
        None, description="Month / day / weekday as sin-cos when `sinusoidal_transformation` (reference: raw values)."
    )
    float32_observations: bool | None = Field(None, description="float32 observations (reference: float64).")


class TradingConfig(EnvConfig):
    """Validated parameters of :class:`~gym4real.trading.env.TradingEnv`."""

    presets_package = "gym4real.trading"

    source: SourceSection = SourceSection()
    splits: SplitsSection = SplitsSection()
    split: SplitName = Field("train", description="The period whose days the episodes are drawn from.")
    anomalous_days: list[dt.date] = Field([], description="Dates to leave out.")
    bar_minutes: int = Field(1, ge=1, description="Bar length (minutes): the price grid of the episodes.")
    persistence: int = Field(5, ge=1, description="Minutes an action is held (a multiple of `bar_minutes`).")
    number_of_deltas: int = Field(
        60,
        ge=1,
        le=1440,
        description="Lagged relative mid-price changes in the observation (at most 1440, a day of one-minute changes).",
    )
    offset: int = Field(1, ge=1, description="Lag (minutes) of each mid-price change (a multiple of `bar_minutes`).")
    sequential: bool = Field(
        False,
        description="Days in order: reset(seed=s) takes day s mod n, reset() the next day (false: a random day).",
    )
    ffill_limit: int = Field(
        5, ge=0, description="Longest gap (minutes) forward-filled; days with longer gaps are dropped."
    )
    capital: float = Field(100_000.0, gt=0, description="Notional of a position (EUR).")
    fees: float = Field(1.0, ge=0, description="Cost per unit of position change (reward units).")
    trading_open: int = Field(8, ge=0, le=23, description="Session start hour (market time).")
    trading_close: int = Field(18, ge=1, le=24, description="Session end hour (market time, exclusive).")
    use_month: bool = Field(False, description="Add the month to the observation.")
    use_day_of_week: bool = Field(False, description="Add the weekday (0 Monday .. 4 Friday).")
    use_day: bool = Field(False, description="Add the day of the month.")
    sinusoidal_transformation: bool = Field(True, description="Time of day (and calendar features) as sin/cos.")
    normalize: bool = Field(True, description="Min-max scale the mid-price changes, fitted on the train split only.")
    fixes: FixesSection = FixesSection()

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        b = self.bar_minutes
        if 1440 % b:
            raise ValueError(f"`bar_minutes` ({b}) must divide a day (1440 minutes)")
        for name in ("persistence", "offset"):
            if getattr(self, name) % b:
                raise ValueError(f"`{name}` ({getattr(self, name)}) must be a multiple of `bar_minutes` ({b})")
        if self.trading_close <= self.trading_open:
            raise ValueError("`trading_close` must be after `trading_open`")
        if (self.trading_open * 60) % b or (self.trading_close * 60) % b:
            raise ValueError(f"the session hours must fall on `bar_minutes` ({b}) boundaries")
        p, n = self.persistence // b, self.session_bars
        if n < 3 * p:
            raise ValueError(f"the session ({n} bars) must hold at least 3 holding periods of {p} bars")
        return self

    @property
    def session_bars(self) -> int:
        """Bars per trading session."""
        return (self.trading_close - self.trading_open) * 60 // self.bar_minutes

    def fix(self, name: str) -> bool:
        """Whether the fix ``name`` of :class:`FixesSection` applies (its switch, else the fidelity)."""
        value = getattr(self.fixes, name)
        return self.fidelity == "corrected" if value is None else bool(value)

    def split_section(self, name: SplitName | None = None) -> SplitSection:
        """The section of a split (the configured one by default)."""
        section: SplitSection = getattr(self.splits, name or self.split)
        return section

    def split_source(self, name: SplitName | None = None) -> SourceSection:
        """The source of a split."""
        return self.split_section(name).source or self.source
