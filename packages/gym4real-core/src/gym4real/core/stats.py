"""Summary statistics of episode returns, from scipy.

Scores across training seeds are matrices ``(seeds, episodes)``: one row per training seed (one row for a
baseline), one column per test episode. Their aggregate is the interquartile mean (IQM) over all seeds and
episodes, as in rliable (Agarwal et al., 2021). Its 95 % confidence interval is a two-level percentile
bootstrap: each replicate resamples a trained agent's seeds (the unit of replication), then the test
episodes, the same episodes for every policy of a comparison (pairing). rliable itself is not used: its
1.2 release needs arch < 8, which fails to import under pandas 3.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy import stats as sps

#: Bootstrap replicates of the confidence intervals.
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


def _replicates(scores: np.ndarray, trained: bool, episodes: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Bootstrap replicates ``(reps, seeds, episodes)`` of a ``(seeds, episodes)`` score matrix.

    A trained agent's seeds (its training runs) are resampled with replacement; a baseline's rows are kept
    (a rule-based policy has no training seed). The test episodes are resampled by ``episodes``
    ``(reps, episodes)``, shared by every matrix of a comparison (pairing by episode).
    """
    n = scores.shape[0]
    reps = len(episodes)
    rows = rng.integers(0, n, size=(reps, n)) if trained else np.broadcast_to(np.arange(n), (reps, n))
    replicates: np.ndarray = scores[rows[:, :, None], episodes[:, None, :]]
    return replicates


def _two_level(
    matrices: Sequence[np.ndarray], trained: Sequence[bool], func: Callable[..., np.ndarray], seed: int
) -> tuple[float, float, float]:
    """``func`` of score matrices and its two-level percentile-bootstrap 95 % CI: ``(value, low, high)``.

    Each replicate resamples the seeds of every trained matrix, then the test episodes (the same ones for
    every matrix). ``func`` takes matrices shaped ``(batch, seeds, episodes)`` and returns one value per batch.
    """
    matrices = [np.atleast_2d(np.asarray(m, dtype=float)) for m in matrices]
    episodes = {m.shape[1] for m in matrices}
    if len(episodes) > 1:
        shapes = " and ".join(str(m.shape[1]) for m in matrices)
        raise ValueError(f"the score matrices have different episodes ({shapes} columns)")
    point = float(func(*(m[None] for m in matrices))[0])
    rng = np.random.default_rng(seed)
    n_episodes = episodes.pop()
    index = rng.integers(0, n_episodes, size=(REPS, n_episodes))
    values = func(*(_replicates(m, t, index, rng) for m, t in zip(matrices, trained, strict=True)))
    low, high = np.percentile(values, [2.5, 97.5])
    return point, float(low), float(high)


def _batched(statistic: str) -> Callable[[np.ndarray], np.ndarray]:
    """The statistic over all runs and episodes of each matrix of a batch ``(batch, runs, episodes)``."""
    if statistic == "iqm":
        return lambda x: sps.trim_mean(x.reshape(len(x), -1), 0.25, axis=1)
    if statistic == "std":
        return lambda x: np.std(x.reshape(len(x), -1), axis=1)
    raise ValueError(f"statistic `{statistic}` is not `iqm` or `std`")


def iqm_ci(scores: np.ndarray, trained: bool, seed: int = 0) -> tuple[float, float, float]:
    """IQM of a ``(seeds, episodes)`` score matrix and its 95 % two-level bootstrap CI: ``(iqm, low, high)``.

    Args:
        scores: One row per training seed (one row for a baseline), one column per test episode.
        trained: Whether the rows are training seeds, resampled first (a baseline's are not).
        seed: Seed of the resampling.
    """
    return _two_level([scores], [trained], _batched("iqm"), seed)


def difference_ci(
    a: np.ndarray, b: np.ndarray, a_trained: bool, b_trained: bool, statistic: str = "iqm", seed: int = 0
) -> tuple[float, float, float]:
    """``statistic(a) - statistic(b)`` and its 95 % two-level bootstrap CI, the test episodes resampled in pairs.

    Args:
        a: Scores ``(seeds, episodes)`` of one policy.
        b: Scores ``(seeds, episodes)`` of the other policy on the same test episodes (any number of seeds).
        a_trained: Whether ``a``'s rows are training seeds (resampled); likewise ``b_trained``.
        b_trained: See ``a_trained``.
        statistic: ``iqm``, or ``std`` (standard deviation over all seeds and episodes).
        seed: Seed of the resampling.
    """
    stat = _batched(statistic)
    return _two_level([a, b], [a_trained, b_trained], lambda x, y: stat(x) - stat(y), seed)


def _improvement(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """P(X > Y) of batches ``(batch, seeds, episodes)``: per episode over every pair of seeds, ties count half."""
    total = np.zeros(len(x))
    for i in range(x.shape[1]):
        for k in range(y.shape[1]):
            a, b = x[:, i], y[:, k]
            total += np.mean((a > b) + 0.5 * (a == b), axis=1)
    result: np.ndarray = total / (x.shape[1] * y.shape[1])
    return result


def probability_of_improvement(
    a: np.ndarray, b: np.ndarray, a_trained: bool, b_trained: bool, seed: int = 0
) -> tuple[float, float, float]:
    """P(a > b) as in rliable, and its 95 % two-level bootstrap CI: ``(p, low, high)``.

    On each test episode, every seed of ``a`` is compared with every seed of ``b`` (a tie counts one half);
    ``p`` is the mean over the seed pairs and episodes, so a policy compared with itself has ``p = 0.5``.
    """
    return _two_level([a, b], [a_trained, b_trained], _improvement, seed)


def performance_profile(scores: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """Fraction of the scores above each threshold (rliable's performance profile, strict ``>``)."""
    x = np.asarray(scores, dtype=float).ravel()
    taus = np.asarray(thresholds, dtype=float)
    profile: np.ndarray = np.mean(x[None, :] > taus[:, None], axis=1)
    return profile


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
