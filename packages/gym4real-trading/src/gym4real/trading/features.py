"""The trading days of a split, their mid prices and the observation features, computed once per config.

Relative mid-price changes ``d_k(t) = (p(t - k*offset) - p(t - (k+1)*offset)) / p(t - (k+1)*offset)``,
k = 0 .. number_of_deltas - 1, are taken either on the continuous bar grid (corrected: a change over a
missing bar, a night without quotes or a weekend is 0, never a jump) or, as the reference, along the
concatenated sessions of the split's kept days (so the first changes of a session span the night or
the removed days before it). Missing changes are 0 in both modes.
"""

from __future__ import annotations

import datetime as dt
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gym4real.core.errors import DataFileError
from gym4real.trading import processing
from gym4real.trading.config import SplitName, TradingConfig


@dataclass
class SplitData:
    """The kept trading days of a split: per day, per session bar, the mid price, time and changes."""

    name: str
    days: list[dt.date]
    mid: np.ndarray  # (n_days, n_bars) float64
    time: np.ndarray  # (n_days, n_bars) datetime64[ns], market time
    deltas: np.ndarray  # (n_days, n_bars, number_of_deltas) float64, unscaled
    dropped: dict[dt.date, str] = field(default_factory=dict)
    sources: list[str] = field(default_factory=list)
    scaler: MinMaxScaler | None = None  # fitted on this split when it is a train split

    def report(self) -> dict[str, Any]:
        """Kept and dropped day counts, with the reasons."""
        return {
            "split": self.name,
            "kept": len(self.days),
            "dropped": len(self.dropped),
            "reasons": processing.drop_summary(self.dropped),
            "dropped_days": {d.isoformat(): r for d, r in sorted(self.dropped.items())},
            "sources": self.sources,
        }


class MinMaxScaler:
    """Column-wise min-max scaling to [0, 1] (scikit-learn's, without the dependency).

    Attributes:
        data_min_: Column minima of the fitted data.
        data_max_: Column maxima of the fitted data.
    """

    def __init__(self) -> None:
        self.data_min_: np.ndarray = np.zeros(0)
        self.data_max_: np.ndarray = np.zeros(0)

    def fit(self, x: np.ndarray) -> MinMaxScaler:
        """Fit on rows of ``x``."""
        self.data_min_ = np.min(x, axis=0)
        self.data_max_ = np.max(x, axis=0)
        return self

    def transform(self, x: np.ndarray) -> np.ndarray:
        """Scale ``x``; values outside the fitted range fall outside [0, 1]; a constant column maps to 0."""
        span = self.data_max_ - self.data_min_
        span = np.where(span == 0, 1.0, span)
        return (x - self.data_min_) / span


def _processing(cfg: TradingConfig) -> processing.Processing:
    return processing.Processing(
        bar_minutes=cfg.bar_minutes,
        ffill_limit=cfg.ffill_limit,
        trading_open=cfg.trading_open,
        trading_close=cfg.trading_close,
        continuous_ffill=cfg.fix("continuous_features"),
    )


def _key(cfg: TradingConfig, name: SplitName, proc: processing.Processed) -> str:
    section = cfg.split_section(name)
    record = {
        "processed": proc.key,
        "bounds": [d.isoformat() for d in section.bounds()],
        "years": section.years,
        "anomalous": sorted(d.isoformat() for d in cfg.anomalous_days),
        "deltas": [cfg.number_of_deltas, cfg.offset, cfg.fix("continuous_features")],
    }
    return json.dumps(record, sort_keys=True, default=str)


_memo: dict[str, SplitData] = {}

#: Weekdays without quotes tolerated at either end of a split (holidays such as 1 January, Good Friday).
UNCOVERED_WEEKDAYS = 2


def check_coverage(name: SplitName, lo: dt.date, hi: dt.date, proc: processing.Processed, where: str) -> None:
    """Refuse quotes that start after or end before the split, beyond :data:`UNCOVERED_WEEKDAYS` weekdays.

    Args:
        name: The split.
        lo: Its first date.
        hi: Its last date.
        proc: The processed quotes of its source.
        where: The source, for the message (a path, a dataset name or a HistData kind).

    Raises:
        DataFileError: Naming the source, the split, the weekdays without quotes and the fix.
    """
    first = proc.first_day
    last = first + dt.timedelta(days=proc.n_days - 1)
    for gap_lo, gap_hi, edge, bound in (
        (lo, min(hi, first - dt.timedelta(days=1)), f"start on {first}", "start"),
        (max(lo, last + dt.timedelta(days=1)), hi, f"end on {last}", "end"),
    ):
        missing = int(np.busday_count(gap_lo, gap_hi + dt.timedelta(days=1))) if gap_lo <= gap_hi else 0
        if missing > UNCOVERED_WEEKDAYS:
            msg = (
                f"the quotes of {where} {edge}, but split `{name}` runs {lo} .. {hi}: {missing} weekdays "
                f"({gap_lo} .. {gap_hi}) have no quotes. Fix: give quotes covering the split, or change "
                f"`splits.{name}.{bound}` (or its `years`) to the period of the data"
            )
            raise DataFileError(msg)


def split_data(cfg: TradingConfig, name: SplitName | None = None) -> SplitData:
    """The kept trading days of a split with their prices and unscaled changes (memoised per config).

    Raises:
        DataFileError: Missing or malformed data, or no complete trading day in the split.
    """
    name = name or cfg.split
    section = cfg.split_section(name)
    lo, hi = section.bounds()
    years = section.years or list(range(lo.year, hi.year + 1))
    source = cfg.split_source(name)
    proc = processing.load(source, years, _processing(cfg), cfg.data_dir)
    where = f"`{source.path}`" if source.path else f"dataset `{source.dataset}`" if source.dataset else source.kind
    check_coverage(name, lo, hi, proc, where)
    key = _key(cfg, name, proc)
    if key not in _memo:
        _memo[key] = _build(cfg, name, proc)
    return _memo[key]


def _build(cfg: TradingConfig, name: SplitName, proc: processing.Processed) -> SplitData:
    section, source = cfg.split_section(name), cfg.split_source(name)
    lo, hi = section.bounds()
    params = proc.params
    anomalous = set(cfg.anomalous_days)
    days = [d for d in proc.kept if section.contains(d) and d not in anomalous]
    dropped = {d: r for d, r in proc.dropped.items() if section.contains(d)}
    dropped.update({d: "listed in `anomalous_days`" for d in proc.kept if section.contains(d) and d in anomalous})
    if not days:
        msg = (
            f"no complete trading day in split `{name}` ({lo} .. {hi}) of {proc.sources or source.kind}: "
            f"{len(dropped)} weekday(s) dropped {processing.drop_summary(dropped)}"
        )
        if proc.spacing_minutes > cfg.bar_minutes:
            msg += (
                f"; the quotes are about {proc.spacing_minutes:g} min apart, coarser than `bar_minutes` "
                f"({cfg.bar_minutes}): use a bar of at least {proc.spacing_minutes:g} min"
            )
        raise DataFileError(msg)
    bpd, ses = params.bars_per_day, params.session
    n_bars = ses.stop - ses.start
    rows = np.array([proc.day_index(d) for d in days])[:, None] * bpd + ses.start + np.arange(n_bars)
    mid = proc.mid[rows]
    first = np.datetime64(proc.first_day, "ns")
    time = first + rows * np.timedelta64(cfg.bar_minutes, "m")
    off = cfg.offset // cfg.bar_minutes
    lags = np.arange(cfg.number_of_deltas) * off
    if cfg.fix("continuous_features"):
        series, index = proc.mid, rows
    else:  # the reference: along the concatenated sessions of the kept days
        series, index = mid.ravel(), np.arange(mid.size).reshape(mid.shape)
    change = np.full(len(series), np.nan)
    change[off:] = (series[off:] - series[:-off]) / series[:-off]  # the reference's expression, to the last bit
    at = index[..., None] - lags  # (n_days, n_bars, n_deltas)
    deltas = np.where(at >= 0, change[np.maximum(at, 0)], np.nan)
    deltas = np.nan_to_num(deltas, nan=0.0, posinf=0.0, neginf=0.0)
    return SplitData(name, days, mid, time, deltas, dropped, proc.sources)


def scaler(cfg: TradingConfig) -> MinMaxScaler:
    """The min-max scaler of the changes, fitted on the train split only (memoised)."""
    train = split_data(cfg, "train")
    if train.scaler is None:
        train.scaler = MinMaxScaler().fit(train.deltas.reshape(-1, cfg.number_of_deltas))
    return train.scaler


def feature_names(cfg: TradingConfig) -> list[str]:
    """Names of the observation's columns, in order (the last is the position)."""
    names = [f"delta_mid_{k}" for k in range(cfg.number_of_deltas)]
    encode = cfg.sinusoidal_transformation and cfg.fix("calendar_encoding")
    for flag, label in ((cfg.use_month, "month"), (cfg.use_day, "day"), (cfg.use_day_of_week, "day_of_week")):
        if flag:
            names += [f"{label}_sin", f"{label}_cos"] if encode else [label]
    names += ["time_sin", "time_cos"] if cfg.sinusoidal_transformation else ["time"]
    return [*names, "position"]


def feature_matrix(cfg: TradingConfig, data: SplitData, dtype: type) -> np.ndarray:
    """Observation columns except the position: ``(n_days, n_bars, n_features)``."""
    deltas = data.deltas
    if cfg.normalize:
        deltas = scaler(cfg).transform(deltas)
    n_days, n_bars = data.mid.shape
    parts = [deltas]
    encode = cfg.sinusoidal_transformation and cfg.fix("calendar_encoding")
    dates = np.array(data.days, dtype="datetime64[D]")
    month = (dates.astype("datetime64[M]").astype(int) % 12 + 1).astype(float)
    day = (dates - dates.astype("datetime64[M]")).astype(int) + 1.0
    weekday = ((dates.astype(int) + 3) % 7).astype(float)
    for flag, values, period in ((cfg.use_month, month, 12), (cfg.use_day, day, 31), (cfg.use_day_of_week, weekday, 5)):
        if flag:
            col = np.broadcast_to(values[:, None, None], (n_days, n_bars, 1))
            if encode:
                ang = 2 * np.pi * col / period
                parts += [np.sin(ang), np.cos(ang)]
            else:
                parts.append(col)
    frac = np.arange(n_bars) * cfg.bar_minutes / ((cfg.trading_close - cfg.trading_open) * 60)
    frac = np.broadcast_to(frac[None, :, None], (n_days, n_bars, 1))
    if cfg.sinusoidal_transformation:
        parts += [np.sin(2 * np.pi * frac), np.cos(2 * np.pi * frac)]
    else:
        parts.append(frac)
    return np.concatenate(parts, axis=2).astype(dtype)
