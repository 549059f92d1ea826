"""Summary statistics of episode returns, from scipy.

Scores across training seeds are matrices ``(runs, episodes)``: one row per training seed, one column per
test episode. Their aggregate is the interquartile mean (IQM) over all runs and episodes, as in rliable
(Agarwal et al., 2021); its 95 % confidence interval is scipy's percentile bootstrap over the test
episodes (rliable's ``task_bootstrap``), each resampled episode keeping the scores of every seed, and
comparisons resample the two policies' episodes in pairs. rliable itself is not used: its 1.2 release
needs arch < 8, which fails to import under pandas 3.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy import stats as sps

#: Bootstrap resamples of the confidence intervals over test episodes.
REPS = 5000


def iqm(values: Sequence[float] | np.ndarray) -> float:
    """Interquartile mean: the mean of the middle 50 % of the values (rliable's IQM, scipy's trim_mean)."""
    x = np.asarray(values, dtype=float)
    return float(sps.trim_mean(x, 0.25, axis=None)) if x.size else float("nan")


def bootstrap_ci(
    values: Sequence[float], level: float = 0.95, n_boot: int = 2000, seed: int = 0
) -> tuple[float, float]:
    """Percentile bootstrap confidence interval of the mean (scipy; seeded, so reports are reproducible)."""
    x = np.asarray(values, dtype=float)
    if len(x) == 0:
        return float("nan"), float("nan")
    if len(x) == 1 or np.all(x == x[0]):
        return float(x[0]), float(x[0])
    res = sps.bootstrap(
        (x,), np.mean, confidence_level=level, n_resamples=n_boot, method="percentile", rng=np.random.default_rng(seed)
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def mean_band(curves: Sequence[np.ndarray], z: float = 1.96) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean and normal 95 % band over episodes of per-step curves of possibly different lengths."""
    length = max(len(c) for c in curves)
    grid = np.full((len(curves), length), np.nan)
    for i, c in enumerate(curves):
        grid[i, : len(c)] = c
    mean = np.nanmean(grid, axis=0)
    count = np.sum(~np.isnan(grid), axis=0)
    sem = np.nanstd(grid, axis=0, ddof=0) / np.sqrt(np.maximum(count, 1))
    return mean, mean - z * sem, mean + z * sem


def t_band(rows: np.ndarray, level: float = 0.95) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean over rows (seeds) and the Student-t confidence band of the mean, column by column (NaN: missing)."""
    mean = np.nanmean(rows, axis=0)
    count = np.sum(~np.isnan(rows), axis=0)
    sem = np.zeros(rows.shape[1])
    many = count > 1  # a column with one seed (a longer curve's tail) has no band
    sem[many] = np.nanstd(rows[:, many], axis=0, ddof=1) / np.sqrt(count[many])
    half = np.where(many, sps.t.ppf(0.5 + level / 2, np.maximum(count - 1, 1)) * sem, 0.0)
    return mean, mean - half, mean + half


def _over_episodes(
    matrices: Sequence[np.ndarray], func: Callable[..., np.ndarray], seed: int
) -> tuple[float, float, float]:
    """``func`` of score matrices and its percentile-bootstrap 95 % CI, resampling the test episodes (columns).

    scipy resamples the episode indices; every matrix takes the same ones (pairing by episode), each keeping
    all its runs. ``func`` takes the matrices with their columns reindexed, shape ``(batch, runs, episodes)``.
    """
    tasks = matrices[0].shape[1]

    def statistic(idx: np.ndarray, axis: int = -1) -> np.ndarray:
        idx = np.atleast_2d(idx)
        return func(*(np.moveaxis(m[:, idx], 1, 0) for m in matrices))

    point = float(statistic(np.arange(tasks))[0])
    if tasks < 2:
        return point, point, point
    res = sps.bootstrap(
        (np.arange(tasks),),
        statistic,
        vectorized=True,
        n_resamples=REPS,
        method="percentile",
        rng=np.random.default_rng(seed),
    )
    return point, float(res.confidence_interval.low), float(res.confidence_interval.high)


def _batched(statistic: str) -> Callable[[np.ndarray], np.ndarray]:
    """The statistic over all runs and episodes of each matrix of a batch ``(batch, runs, episodes)``."""
    if statistic == "iqm":
        return lambda x: sps.trim_mean(x.reshape(len(x), -1), 0.25, axis=1)
    if statistic == "std":
        return lambda x: np.std(x.reshape(len(x), -1), axis=1)
    raise ValueError(f"statistic `{statistic}` is not `iqm` or `std`")


def iqm_ci(scores: np.ndarray, seed: int = 0) -> tuple[float, float, float]:
    """IQM of a ``(runs, episodes)`` score matrix and its 95 % CI over the test episodes: ``(iqm, low, high)``."""
    return _over_episodes([np.asarray(scores, dtype=float)], _batched("iqm"), seed)


def difference_ci(a: np.ndarray, b: np.ndarray, statistic: str = "iqm", seed: int = 0) -> tuple[float, float, float]:
    """``statistic(a) - statistic(b)`` and its 95 % CI, the test episodes resampled in pairs.

    Args:
        a: Scores ``(runs, episodes)`` of one policy.
        b: Scores ``(runs, episodes)`` of the other policy on the same test episodes (any number of runs).
        statistic: ``iqm``, or ``std`` (standard deviation over all runs and episodes).
        seed: Seed of the resampling.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"the two score matrices have different episodes ({a.shape[1]} and {b.shape[1]} columns)")
    stat = _batched(statistic)
    return _over_episodes([a, b], lambda x, y: stat(x) - stat(y), seed)


def verdict(relation: str, low: float, high: float) -> str:
    """``holds``, ``does not hold`` or ``inconclusive`` for the CI ``[low, high]`` of a difference (policy - other).

    ``above``: holds when the interval is above 0; ``below`` and ``less_variable``: when it is below 0;
    ``not_above``: holds unless the interval is above 0. An interval containing 0 is inconclusive.
    """
    if relation == "not_above":
        return "does not hold" if low > 0 else "holds"
    if relation == "above":
        low, high = -high, -low
    if high < 0:
        return "holds"
    if low > 0:
        return "does not hold"
    return "inconclusive"
