"""Summary statistics of episode returns, as reported by the benchmark harness."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def iqm(values: Sequence[float]) -> float:
    """Interquartile mean: the mean of the middle 50 % of the values (rliable's IQM)."""
    x = np.sort(np.asarray(values, dtype=float))
    n = len(x)
    if n == 0:
        return float("nan")
    cut = int(np.floor(n * 0.25))
    return float(x[cut : n - cut].mean())


def bootstrap_ci(
    values: Sequence[float], level: float = 0.95, n_boot: int = 2000, seed: int = 0
) -> tuple[float, float]:
    """Percentile bootstrap confidence interval of the mean (seeded, so reports are reproducible)."""
    x = np.asarray(values, dtype=float)
    if len(x) == 0:
        return float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    means = x[rng.integers(0, len(x), size=(n_boot, len(x)))].mean(axis=1)
    alpha = (1 - level) / 2
    return float(np.quantile(means, alpha)), float(np.quantile(means, 1 - alpha))


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
