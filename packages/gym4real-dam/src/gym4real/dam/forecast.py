"""Forecasts of the dam's inflow and demand from the training years, for the causal ``mpc`` baseline.

A forecast of a series (inflow or demand) has two parts, both fitted on the training split only
(``dam/inflow/train``, ``dam/demand/train``: the 52 years an agent trains on; never the test years):

- the **climatology**: a statistic over the training years of the value of each day of the year
  (``statistic="mean"``, or a quantile such as ``0.5``);
- the **persistence** of an anomaly: the coefficients ``b_k`` (k = 1, 2, ...) of the least-squares
  regression, pooled over the training years and days, of the anomaly ``x - climatology`` of a day on the
  anomaly of the day ``k`` days before it, within a year. The forecast of a day ``k`` days after the last
  observed one is ``climatology + b_k * (last observed anomaly)``, floored at 0; with nothing observed yet
  (the first day of an episode) it is the climatology.

:func:`series_forecast` fits one from a yearly table; ``leave_out`` drops years from the fit, so that an
episode of a training year is forecast without its own data (the :class:`~gym4real.dam.mpc.DamMPC` does
so on the train split; the test split's years are never in the fit).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass

import numpy as np

from gym4real.core.errors import ConfigError
from gym4real.dam.data import DAYS, YearlyTable, calendar_days


@dataclass(frozen=True)
class SeriesForecast:
    """A fitted forecast of one series (see the module docstring).

    Attributes:
        climatology: ``(365,)``: the statistic of each 0-based day of the year over the training years.
        persistence: ``(lags,)``: ``b_k`` for ``k = 1 .. lags``; an anomaly is forgotten after ``lags`` days.
    """

    climatology: np.ndarray
    persistence: np.ndarray

    def predict(self, days: Sequence[int], last: float | None, last_day: int | None) -> np.ndarray:
        """The forecast of the consecutive days ``days`` (0-based days of the year).

        Args:
            days: The days to forecast, the first one the day after ``last_day``.
            last: The value observed on the last observed day; None: nothing observed (the climatology).
            last_day: The 0-based day of the year of ``last``.

        Returns:
            ``(len(days),)``, non-negative.
        """
        forecast = self.climatology[np.asarray(days, dtype=np.int64)].copy()
        if last is not None and last_day is not None:
            anomaly = last - self.climatology[last_day]
            lags = min(len(forecast), self.persistence.size)
            forecast[:lags] += self.persistence[:lags] * anomaly
        return np.maximum(forecast, 0.0)


def training_matrix(table: YearlyTable, drop_feb29: bool, leave_out: Collection[int] = ()) -> np.ndarray:
    """The training years' values, ``(years, 365)``, by 0-based day of the year (without the years ``leave_out``)."""
    years = [y for y in table.years if y not in leave_out]
    if not years:
        raise ConfigError(f"`{table.path}` holds no year besides {sorted(leave_out)}: nothing to fit a forecast on")
    return np.array([calendar_days(table, y, drop_feb29) for y in years], dtype=np.float64)


def series_forecast(values: np.ndarray, statistic: float | str, lags: int) -> SeriesForecast:
    """Fit a forecast on the training years' values.

    Args:
        values: ``(years, 365)``: each training year's value of each day (:func:`training_matrix`).
        statistic: ``"mean"``, or a quantile in [0, 1] of each day's values over the years.
        lags: How many days ahead an anomaly is carried (the ``b_k`` fitted), at least 0.

    Raises:
        ConfigError: An unknown statistic, a quantile outside [0, 1], a negative ``lags`` or one of a
            year or more, or values that are not ``(years, 365)`` and finite.
    """
    if values.ndim != 2 or values.shape[1] != DAYS or values.shape[0] < 1 or not np.all(np.isfinite(values)):
        raise ConfigError(f"a forecast is fitted on finite (years, {DAYS}) values, not an array of {values.shape}")
    if not 0 <= lags < DAYS:
        raise ConfigError(f"forecast `lags` must be a number of days in [0, {DAYS - 1}], not {lags}")
    if statistic == "mean":
        climatology = values.mean(axis=0)
    elif isinstance(statistic, float | int) and not isinstance(statistic, bool) and 0.0 <= statistic <= 1.0:
        climatology = np.quantile(values, float(statistic), axis=0)
    else:
        raise ConfigError(f'forecast `statistic` must be "mean" or a quantile in [0, 1], not {statistic!r}')
    anomaly = values - climatology
    persistence = np.zeros(lags)
    for k in range(1, lags + 1):
        before, after = anomaly[:, :-k], anomaly[:, k:]
        variance = float(np.sum(before * before))
        persistence[k - 1] = float(np.sum(before * after)) / variance if variance > 0 else 0.0
    return SeriesForecast(climatology, persistence)
