"""Summary statistics of test scores, from numpy and scipy (the ``bench`` extra, imported on first use).

The scores of a policy are a matrix ``(runs, episodes)``: one row per training seed of an RL algorithm
(one row for a baseline, which is not trained), one column per test episode; every policy plays the same
test episodes, column ``j`` being the same episode for all. Aggregates follow rliable (Agarwal et al.,
2021): the interquartile mean (IQM) over all runs and episodes, the probability of improvement and the
performance profile. rliable itself is not used (its 1.2 release does not import under pandas 3 and its
repository is archived).

Intervals come from a **two-level (seed, episode) percentile bootstrap**: each replicate draws the test
episodes with replacement once, and every policy takes those same episodes (pairing by episode); the rows
of a trained policy's matrix (its training seeds) are drawn with replacement too, one draw per policy, so
that the interval covers the variability of training, not only of these trained networks; a baseline's
row is kept. A statistic of several policies (a difference) is computed on the same replicate.

**Replicates grow with the level.** An end of a percentile interval at level ``L`` is the quantile
``(1 - L) / 2`` of the replicates: with a fixed number of replicates a Bonferroni level of 0.997 leaves a
handful beyond each end, and the end moves with the bootstrap's seed. Every interval therefore takes
:func:`replicates_at` its level: at least :data:`REPS`, and enough that :data:`TAIL` replicates lie beyond
each end (16,000 at 95 %, about 290,000 at 0.9972), so that an end moves by a few percent of its
interval's width between seeds (``tests/test_results_page.py`` reruns every published claim with five seeds).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from gym4real.core.install_hint import import_extra

#: Bootstrap replicates of an interval at the least (a 95 % interval takes more: :func:`replicates_at`).
REPS = 5000
#: Replicates beyond each end of an interval (:func:`replicates_at`).
TAIL = 400
#: Replicates drawn at once (bounds the memory of a batch to ``CHUNK x runs x episodes`` scores).
CHUNK = 500
#: Values within this fraction of the scores' magnitude are float noise and taken as 0 (see :func:`snap`).
RTOL = 1e-9

Batched = Callable[..., np.ndarray]


def scipy_stats() -> Any:
    """``scipy.stats`` (the ``bench`` extra of gym4real-core), or the error naming that extra."""
    return import_extra("scipy.stats", "bench")


def replicates_at(level: float) -> int:
    """The bootstrap replicates of an interval at ``level``: :data:`REPS`, or :data:`TAIL` beyond each end."""
    if not 0.0 < level < 1.0:
        raise ValueError(f"a confidence level must lie in (0, 1), not {level}")
    return max(REPS, math.ceil(TAIL / ((1.0 - level) / 2.0) - 1e-6))


def iqm_last(x: np.ndarray) -> np.ndarray:
    """The IQM along the last axis: the mean of the middle values, ``int(n / 4)`` cut from each end.

    scipy's ``trim_mean(x, 0.25)``, by sorting: its two-point partition is slower on the bootstrap's small rows.
    """
    n = x.shape[-1]
    cut = int(0.25 * n)
    result: np.ndarray = np.sort(x, axis=-1)[..., cut : n - cut].mean(axis=-1)
    return result


def iqm(values: Sequence[float] | np.ndarray) -> float:
    """Interquartile mean: the mean of the middle 50 % of the values (rliable's IQM, scipy's trim_mean)."""
    x = np.asarray(values, dtype=float)
    return float(iqm_last(x.ravel())) if x.size else float("nan")


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
    """Mean over rows (seeds) and the Student-t confidence band of the mean, column by column (NaN: missing).

    A column with fewer than two values has no band: its bounds are NaN.
    """
    mean = np.nanmean(rows, axis=0)
    count = np.sum(~np.isnan(rows), axis=0)
    many = count > 1
    half = np.full(rows.shape[1], np.nan)
    sem = np.nanstd(rows[:, many], axis=0, ddof=1) / np.sqrt(count[many])
    half[many] = scipy_stats().t.ppf(0.5 + level / 2, count[many] - 1) * sem
    return mean, mean - half, mean + half


def _matrices(matrices: Sequence[np.ndarray]) -> list[np.ndarray]:
    """The score matrices as float arrays, checked: 2-D, finite, the same number of test episodes."""
    found = [np.asarray(m, dtype=float) for m in matrices]
    for i, m in enumerate(found):
        if m.ndim != 2 or m.size == 0:
            raise ValueError(f"score matrix {i} has shape {m.shape}; expected (runs, episodes), both at least 1")
        if not np.all(np.isfinite(m)):
            raise ValueError(f"score matrix {i} holds non-finite scores; fix the episodes that produced them")
    if len({m.shape[1] for m in found}) > 1:
        raise ValueError(
            f"the score matrices have different test episodes ({[m.shape[1] for m in found]} columns); every "
            "policy must play the same episodes"
        )
    return found


def resample(
    matrices: Sequence[np.ndarray], trained: Sequence[bool], rng: np.random.Generator, reps: int
) -> list[np.ndarray]:
    """``reps`` two-level bootstrap replicates of each matrix, each of shape ``(reps, runs, episodes)``.

    The episode indices are drawn once per replicate and shared by every matrix; the rows of each trained
    matrix are drawn per replicate and per matrix; a matrix not trained keeps its rows.
    """
    episodes = matrices[0].shape[1]
    cols = rng.integers(episodes, size=(reps, 1, episodes))
    out = []
    for m, was_trained in zip(matrices, trained, strict=True):
        runs = m.shape[0]
        rows = rng.integers(runs, size=(reps, runs, 1)) if was_trained else np.arange(runs)[None, :, None]
        out.append(m[rows, cols])
    return out


def replicates(
    matrices: Sequence[np.ndarray], trained: Sequence[bool], func: Batched, seed: int = 0, reps: int = REPS
) -> np.ndarray:
    """``func`` on ``reps`` two-level bootstrap replicates (see :func:`resample`), seeded.

    Args:
        matrices: Score matrices ``(runs, episodes)`` on the same test episodes.
        trained: Per matrix, whether its rows are training seeds (resampled) or not (a baseline).
        func: Maps the batched matrices, each ``(batch, runs, episodes)``, to the statistic of each replicate,
            shape ``(batch,)`` or ``(batch, k)``.
        seed: Seed of the resampling.
        reps: Number of replicates.
    """
    found = _matrices(matrices)
    if len(trained) != len(found):
        raise ValueError(f"`trained` has {len(trained)} entries for {len(found)} score matrices")
    rng = np.random.default_rng(seed)
    parts = []
    for start in range(0, reps, CHUNK):
        parts.append(np.asarray(func(*resample(found, trained, rng, min(CHUNK, reps - start))), dtype=float))
    return np.concatenate(parts)


def bounds(
    matrices: Sequence[np.ndarray],
    trained: Sequence[bool],
    func: Batched,
    seed: int = 0,
    reps: int | None = None,
    level: float = 0.95,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``func`` of the matrices and its two-level percentile-bootstrap interval, as arrays (vector statistics).

    ``reps``: the replicates; None: :func:`replicates_at` the level.
    """
    found = _matrices(matrices)
    point = np.asarray(func(*(m[None] for m in found)), dtype=float)[0]
    values = replicates(found, trained, func, seed, replicates_at(level) if reps is None else reps)
    low, high = np.percentile(values, [50 * (1 - level), 50 * (1 + level)], axis=0)
    return point, low, high


def interval(
    matrices: Sequence[np.ndarray],
    trained: Sequence[bool],
    func: Batched,
    seed: int = 0,
    reps: int | None = None,
    level: float = 0.95,
) -> tuple[float, float, float]:
    """A scalar statistic of score matrices and its two-level (seed, episode) percentile-bootstrap interval.

    Args:
        matrices: Score matrices ``(runs, episodes)`` on the same test episodes.
        trained: Per matrix, whether its rows are training seeds (resampled) or not (a baseline).
        func: Maps the batched matrices, each ``(batch, runs, episodes)``, to ``(batch,)`` values.
        seed: Seed of the resampling.
        reps: Number of replicates; None: :func:`replicates_at` the level.
        level: Confidence level.

    Returns:
        ``(point, low, high)``: the statistic of the matrices as given and the interval's bounds.
    """
    point, low, high = bounds(matrices, trained, func, seed, reps, level)
    return float(point), float(low), float(high)


def batched(statistic: str) -> Batched:
    """A statistic of each matrix of a batch ``(batch, runs, episodes)``.

    ``iqm`` and ``mean``: over all runs and episodes; ``spread``: the standard deviation across test
    episodes of each run, averaged over runs (a policy's episode-to-episode variability, not including the
    differences between its training seeds).
    """
    if statistic == "iqm":
        return lambda x: iqm_last(x.reshape(len(x), -1))
    if statistic == "mean":
        return lambda x: x.mean(axis=(1, 2))
    if statistic == "spread":
        return lambda x: x.std(axis=2).mean(axis=1)
    raise ValueError(f"statistic `{statistic}` is not `iqm`, `mean` or `spread`")


def snap(value: float, scale: float) -> float:
    """``value``, or 0.0 when it is float noise: within :data:`RTOL` of ``scale`` (the scores' magnitude)."""
    return 0.0 if abs(value) <= RTOL * scale else value


def iqm_ci(scores: np.ndarray, trained: bool, seed: int = 0, level: float = 0.95) -> tuple[float, float, float]:
    """IQM of a ``(runs, episodes)`` score matrix and its two-level bootstrap interval: ``(iqm, low, high)``."""
    return interval([scores], [trained], batched("iqm"), seed, level=level)


def difference_ci(
    a: np.ndarray,
    b: np.ndarray,
    a_trained: bool,
    b_trained: bool,
    statistic: str = "iqm",
    seed: int = 0,
    level: float = 0.95,
) -> tuple[float, float, float]:
    """``statistic(a) - statistic(b)`` and its interval, both policies resampled jointly (same episodes).

    Values within float noise of 0 (see :func:`snap`, relative to the largest score) are 0.

    Args:
        a: Scores ``(runs, episodes)`` of one policy.
        b: Scores ``(runs, episodes)`` of the other policy on the same test episodes (any number of runs).
        a_trained: Whether ``a``'s rows are training seeds.
        b_trained: Whether ``b``'s rows are training seeds.
        statistic: ``iqm``, ``mean`` or ``spread`` (see :func:`batched`).
        seed: Seed of the resampling.
        level: Confidence level.
    """
    stat = batched(statistic)
    found = _matrices([a, b])
    scale = max(float(np.abs(m).max()) for m in found)
    diff, low, high = interval(found, [a_trained, b_trained], lambda x, y: stat(x) - stat(y), seed, level=level)
    return snap(diff, scale), snap(low, scale), snap(high, scale)


def per_row(statistic: str) -> Batched:
    """A statistic of each row (run) of each matrix of a batch ``(batch, runs, episodes)``: ``(batch, runs)``.

    ``iqm`` and ``mean``: over the row's episodes; ``spread``: the standard deviation across its episodes.
    """
    if statistic == "iqm":
        return iqm_last
    if statistic == "mean":
        return lambda x: x.mean(axis=2)
    if statistic == "spread":
        return lambda x: x.std(axis=2)
    raise ValueError(f"statistic `{statistic}` is not `iqm`, `mean` or `spread`")


def per_seed_difference_ci(
    a: np.ndarray,
    b: np.ndarray,
    b_trained: bool,
    statistic: str = "iqm",
    seed: int = 0,
    level: float = 0.95,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row (training seed) ``i`` of ``a``: ``statistic(a[i]) - statistic(b)`` and its own interval.

    Each replicate draws the test episodes with replacement, the same ones for ``a`` and ``b`` (pairing by
    episode); the row ``a[i]`` is kept (the interval is this seed's, not the algorithm's), ``b``'s rows are
    drawn too when ``b_trained``. Values within float noise of 0 (see :func:`snap`) are 0.

    Returns:
        ``(estimates, lows, highs)``, each of shape ``(runs of a,)``.
    """
    row, pooled = per_row(statistic), batched(statistic)
    found = _matrices([a, b])
    scale = max(float(np.abs(m).max()) for m in found)
    point, low, high = bounds(found, [False, b_trained], lambda x, y: row(x) - pooled(y)[:, None], seed, level=level)
    noise = np.abs(np.stack([point, low, high])) <= RTOL * scale
    point, low, high = np.where(noise, 0.0, np.stack([point, low, high]))
    return point, low, high


def _improvement(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """P(X > Y) of each replicate: over episodes and run pairs, 1 when x > y, 1/2 when tied (counted exactly)."""
    halves = np.zeros(len(x), dtype=np.int64)  # twice the wins: 2 per win, 1 per tie
    for i in range(x.shape[1]):  # one run of x at a time bounds the memory
        xi = x[:, i : i + 1, :]
        halves += 2 * (xi > y).sum(axis=(1, 2)) + (xi == y).sum(axis=(1, 2))
    return halves / (2 * x.shape[1] * y.shape[1] * x.shape[2])


def probability_of_improvement(
    a: np.ndarray, b: np.ndarray, a_trained: bool, b_trained: bool, seed: int = 0, level: float = 0.95
) -> tuple[float, float, float]:
    """The probability of improvement P(a > b) of rliable, with each test episode as a task, and its interval.

    For score matrices ``a`` (n runs) and ``b`` (m runs) on the same E test episodes::

        P(a > b) = 1 / E sum_j 1 / (n m) sum_i sum_k [a_ij > b_kj] + 1/2 [a_ij = b_kj]

    the Mann-Whitney U / (n m) of the two policies' runs on episode ``j``, averaged over episodes: the
    chance that a run of ``a`` scores more than a run of ``b`` on the same episode, ties counting 1/2. A
    policy against itself scores exactly 1/2. The interval is the two-level bootstrap's.
    """
    return interval([a, b], [a_trained, b_trained], _improvement, seed, level=level)


def performance_profile(scores: np.ndarray, thresholds: Sequence[float] | np.ndarray) -> np.ndarray:
    """The fraction of all (run, episode) scores above each threshold (rliable's score distribution)."""
    x = _matrices([scores])[0]
    return np.array([float(np.mean(x > t)) for t in np.asarray(thresholds, dtype=float)])


def profile_band(
    scores: np.ndarray, trained: bool, thresholds: Sequence[float] | np.ndarray, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`performance_profile` and its pointwise two-level bootstrap 95 % band, as ``(point, low, high)``."""
    tau = np.asarray(thresholds, dtype=float)
    return bounds([scores], [trained], lambda x: (x.reshape(len(x), -1, 1) > tau).mean(axis=1), seed)


def per_seed(scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """IQM and mean over test episodes of each run (row) of a score matrix."""
    x = _matrices([scores])[0]
    return iqm_last(x), x.mean(axis=1)


def verdict(relation: str, low: float, high: float, margin: float | None = None) -> tuple[str, str]:
    """The verdict of one comparison from the interval ``[low, high]`` of a difference (policy - other).

    ``above``: holds when the interval lies above 0, is refuted when it lies at or below 0;
    ``below`` and ``less_variable``: the mirror image; otherwise inconclusive. ``not_above`` (the margin
    reading of a negative claim, with its margin of practical equivalence): holds when the interval lies
    below ``+margin``, is refuted when it lies above 0, else inconclusive.

    Returns:
        ``(verdict, rule)``: ``holds``, ``refuted`` or ``inconclusive``, and the name of the rule that
        decided it (``interval above 0``, ...).
    """
    if relation == "not_above":
        if margin is None or not margin > 0:
            raise ValueError(f"a `not_above` comparison needs a positive margin of practical equivalence, not {margin}")
        if low > 0:
            return "refuted", "interval above 0"
        if high < margin:
            return "holds", "interval below the margin"
        return "inconclusive", "interval reaches the margin and 0"
    if relation not in ("above", "below", "less_variable"):
        raise ValueError(f"relation `{relation}` is not `above`, `below`, `not_above` or `less_variable`")
    if relation == "above":
        if low > 0:
            return "holds", "interval above 0"
        if high <= 0:
            return "refuted", "interval at or below 0"
    else:
        if high < 0:
            return "holds", "interval below 0"
        if low >= 0:
            return "refuted", "interval at or above 0"
    return "inconclusive", "interval contains 0"
