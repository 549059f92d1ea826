"""Multi-objective metrics of a set of objective vectors: Pareto front, hypervolume and expected utility.

Every objective is maximised. Vectors are compared on the **normalised scale** of an id
(:mod:`gym4real.bench.mo_reference`): ``z = (v - reference_point) / (top - reference_point)`` per objective,
so that the fixed reference point is 0 and ``random``'s best test episode is 1; the raw objectives of a
domain differ by orders of magnitude (EUR against EUR, but hours of demand against overflow penalties), and
a weight on a raw scale would weigh mostly the units.

- **Hypervolume**: the volume of the normalised space dominated by the set and dominating the reference
  point (0), computed by ``moocore`` (López-Ibáñez et al.; a maintained C implementation); vectors that do
  not dominate the reference point add nothing.
- **Expected utility (EUM)**: Zintgraf et al. (2015), as MORL-Baselines reports it: the mean over a fixed
  set of weights ``w`` of ``max_p w . z_p``, the best linear utility the set offers. The weights are the
  Das-Dennis simplex lattice, equally spaced weights summing to 1 (the first of at least
  :data:`WEIGHTS` of them: 50 for two objectives, 55 for three).
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from gym4real.core.errors import ConfigError

#: The fewest weights of the EUM's simplex lattice (MORL-Baselines evaluates EUM over 50 to 100 weights).
WEIGHTS = 50


def simplex_weights(objectives: int, least: int = WEIGHTS) -> np.ndarray:
    """The Das-Dennis lattice: every weight vector with entries ``k / H`` summing to 1, ``(count, objectives)``.

    ``H`` is the smallest number of divisions that gives at least ``least`` vectors (``C(H + m - 1, m - 1)``
    of them for ``m`` objectives). Rows are in lexicographic order of the first entries, descending.

    Raises:
        ValueError: Fewer than two objectives, or ``least`` below 1.
    """
    if objectives < 2 or least < 1:
        raise ValueError(f"a weight lattice needs at least two objectives and one weight, not {objectives}, {least}")
    divisions = 1
    while math.comb(divisions + objectives - 1, objectives - 1) < least:
        divisions += 1
    rows = []
    # stars and bars: the positions of the m - 1 bars among H + m - 1 slots give the parts of H
    for bars in itertools.combinations(range(divisions + objectives - 1), objectives - 1):
        edges = (-1, *bars, divisions + objectives - 1)
        rows.append([edges[i + 1] - edges[i] - 1 for i in range(objectives)])
    return np.array(rows[::-1], dtype=float) / divisions


def _moocore() -> Any:
    """The ``moocore`` module (extra ``mo``), or an error that says how to install it."""
    try:
        import moocore
    except ImportError as exc:
        raise ConfigError(
            'multi-objective metrics need moocore (the `mo` extra): `pip install "gym4real-core[mo]"`'
        ) from exc
    return moocore


def nondominated(points: np.ndarray) -> np.ndarray:
    """A boolean mask of the points no other point dominates (maximising; duplicates are all kept)."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    return np.asarray(_moocore().is_nondominated(points, maximise=True, keep_weakly=True))


def hypervolume(points: np.ndarray, reference: np.ndarray | None = None) -> float:
    """The hypervolume of ``points`` (maximised) above ``reference`` (default: the origin, the normalised scale's).

    Raises:
        ValueError: A non-finite point or reference.
    """
    points = np.atleast_2d(np.asarray(points, dtype=float))
    ref = np.zeros(points.shape[1]) if reference is None else np.asarray(reference, dtype=float)
    if not (np.isfinite(points).all() and np.isfinite(ref).all()):
        raise ValueError("hypervolume of non-finite objective values: every episode's objectives must be finite")
    inside = points[(points > ref).all(axis=1)]  # only a point dominating the reference point adds volume
    if not len(inside):
        return 0.0
    return float(_moocore().hypervolume(inside, ref=ref, maximise=True))


def expected_utility(points: np.ndarray, weights: np.ndarray) -> float:
    """The mean over ``weights`` (rows) of the best linear utility ``max_p w . z_p`` among ``points``."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    return float((np.asarray(weights, dtype=float) @ points.T).max(axis=1).mean())
