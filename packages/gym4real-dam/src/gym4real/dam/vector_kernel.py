"""The batched dam's day as one compiled loop over the copies and sub-steps (numba).

:class:`~gym4real.dam.vector.DamVectorEnv` runs :func:`integrate_copies` when numba is installed (the extra
``fast``) and numpy otherwise. Each sub-step evaluates the numpy path's expressions in the same order
(IEEE-exact divisions, products and sums, and the same ``pow``); only the rating curve of a copy below
``l_lim``, which the numpy path computes and discards, is skipped. A test steps both side by side.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _release(h: float, wanted: float, lake: tuple[float, ...]) -> float:
    """The release at level ``h``: 0 up to l_min, else ``min(q_max(h), wanted)`` (``q_max(h)`` above l_max)."""
    lmin, lmax, llim, k, c, alpha, beta, cr = lake[1], lake[2], lake[3], lake[4], lake[5], lake[6], lake[7], lake[8]
    if h <= lmin:
        return 0.0
    q_max = h * k + c if h <= llim else ((h - alpha) ** beta) * cr
    return q_max if h > lmax or q_max < wanted else wanted


@njit(cache=True)
def _constant(h: float, wanted: float, lake: tuple[float, ...]) -> int:
    """Which constant release level ``h`` gives, if any.

    Returns:
        0 (nothing, up to l_min), 1 (``wanted``, up to the linear limit), 2 (``wanted``, on the rating
        curve), or -1 (a release that follows the level).
    """
    lmin, lmax, llim = lake[1], lake[2], lake[3]
    if h <= lmin:
        return 0
    if h > lmax or _release(h, wanted, lake) != wanted:
        return -1
    return 1 if h <= llim else 2


@njit(cache=True)
def integrate_copies(
    storage: np.ndarray,
    wanted: np.ndarray,
    inflow: np.ndarray,
    evaporation: np.ndarray,
    lake: tuple[float, float, float, float, float, float, float, float, float, float],
    evaporates: bool,
    releases: np.ndarray,
) -> None:
    """Integrate every copy's day: ``storage`` updated in place, each sub-step's release in ``releases``.

    Per sub-step, as the numpy path: ``h = s / A + l_min``, the release (:func:`_release`) and
    ``s += dt ((inflow - release) - evaporation)``. A day whose first and last sub-steps release the same
    constant (nothing, or the wanted release on the same branch of ``q_max``) releases it in every
    sub-step: the level moves monotonically and the rounded ``q_max`` is monotone in it within a branch,
    so only those two sub-steps evaluate the release.

    Args:
        storage: Each copy's storage (m3), updated.
        wanted: ``max(q_min, decision)`` per copy (m3/s).
        inflow: The day's inflow per copy (m3/s).
        evaporation: The day's evaporation per copy (m3/s).
        lake: Surface, l_min, l_max, l_lim, linear slope and intercept, alpha, beta, C_r, dt.
        evaporates: Whether any evaporation is subtracted (the numpy path's ``_evaporation``).
        releases: Out, ``(sub-steps, copies)``: the release of every sub-step.
    """
    area, lmin, dt = lake[0], lake[1], lake[9]
    substeps = releases.shape[0]
    others = np.empty(storage.size, dtype=np.int64)  # the copies whose release follows the level
    n_others = 0
    for i in range(storage.size):
        s0, m = storage[i], wanted[i]
        first = _constant(s0 / area + lmin, m, lake)
        if first >= 0:
            r = m if first > 0 else 0.0
            net = inflow[i] - r
            if evaporates:
                net -= evaporation[i]
            step = net * dt
            s = s0
            for _ in range(substeps - 1):
                s += step
            if _constant(s / area + lmin, m, lake) == first:
                releases[:, i] = r
                storage[i] = s + step
                continue
        others[n_others] = i
        n_others += 1
    for j in range(substeps):  # sub-step by sub-step across the copies: independent work, no waiting on one chain
        for o in range(n_others):
            i = others[o]
            r = _release(storage[i] / area + lmin, wanted[i], lake)
            releases[j, i] = r
            net = inflow[i] - r
            if evaporates:
                net -= evaporation[i]
            storage[i] += net * dt
