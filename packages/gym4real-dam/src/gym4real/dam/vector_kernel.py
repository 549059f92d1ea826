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

    Args:
        storage: Each copy's storage (m3), updated.
        wanted: ``max(q_min, decision)`` per copy (m3/s).
        inflow, evaporation: The day's flows per copy (m3/s).
        lake: Surface, l_min, l_max, l_lim, linear slope and intercept, alpha, beta, C_r, dt.
        evaporates: Whether any evaporation is subtracted (the numpy path's ``_evaporation``).
        releases: Out, ``(sub-steps, copies)``: the release of every sub-step.
    """
    area, lmin, lmax, llim, k, c, alpha, beta, cr, dt = lake
    for i in range(storage.size):
        s = storage[i]
        for j in range(releases.shape[0]):
            h = s / area + lmin
            if h <= lmin:
                r = 0.0
            else:
                q_max = h * k + c if h <= llim else ((h - alpha) ** beta) * cr
                r = q_max if h > lmax or q_max < wanted[i] else wanted[i]
            releases[j, i] = r
            net = inflow[i] - r
            if evaporates:
                net -= evaporation[i]
            s += net * dt
        storage[i] = s
