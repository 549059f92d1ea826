"""The Lake Como model of the paper's appendix: mass balance with level-dependent release bounds.

A day is integrated in ``n`` equal sub-steps. In each, the level is ``h = s / A + l_min``, the release
is the decision clipped into ``[q_min(h, t), q_max(h)]`` and the storage moves by
``dt * (inflow - release - evaporation)``. The day returns the final storage and the mean release.

Speed: the per-sub-step bound evaluation is skipped whenever the level provably stays in the band where
the clipped decision is feasible (a margin of 1e-9 m keeps every skipped case exact), and the mean uses
the same pairwise summation as ``numpy.mean``, so results are bit-identical to the straightforward loop.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

SECONDS_PER_DAY = 86_400.0
_MARGIN = 1e-9  # m; far above rounding error, far below any physical effect
_Q_MARGIN = 1e-6  # m3/s; the same for releases (q_max rises by >= 1e-6 m3/s per 1e-9 m here)


def np_sum(values: Sequence[float]) -> float:
    """Sum in the order of numpy's pairwise summation (``numpy.add.reduce`` on a contiguous float64 array)."""
    n = len(values)
    if n < 8:
        res = -0.0
        for v in values:
            res += v
        return res
    if n <= 128:
        r0, r1, r2, r3, r4, r5, r6, r7 = values[:8]
        i = 8
        top = n - n % 8
        while i < top:
            r0 += values[i]
            r1 += values[i + 1]
            r2 += values[i + 2]
            r3 += values[i + 3]
            r4 += values[i + 4]
            r5 += values[i + 5]
            r6 += values[i + 6]
            r7 += values[i + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += values[i]
            i += 1
        return res
    half = n // 2
    half -= half % 8
    return np_sum(values[:half]) + np_sum(values[half:])


class Lake:
    """The reservoir: storage-level relation, release bounds and daily integration.

    Args:
        surface: Surface A (m2).
        min_level: l_min (m); storage 0.
        max_level: l_max (m); above it the release follows the rating curve.
        alpha: Zero-flow level of the rating curve (m).
        beta: Rating-curve exponent.
        C_r: Rating-curve coefficient.
        linear_slope: k of the linear branch of q_max.
        linear_intercept: c of the linear branch of q_max.
        linear_limit: l_lim (m), top of the linear branch.
        substeps: Sub-steps per day.
    """

    def __init__(
        self,
        surface: float,
        min_level: float,
        max_level: float,
        alpha: float,
        beta: float,
        C_r: float,
        linear_slope: float,
        linear_intercept: float,
        linear_limit: float,
        substeps: int,
    ) -> None:
        self.surface = surface
        self.min_level = min_level
        self.max_level = max_level
        self.alpha = alpha
        self.beta = beta
        self.C_r = C_r
        self.linear_slope = linear_slope
        self.linear_intercept = linear_intercept
        self.linear_limit = linear_limit
        self.substeps = substeps
        self.dt = SECONDS_PER_DAY / substeps
        # q_max at the top of the linear branch: below it the linear branch decides the safe level
        self._linear_top = linear_slope * linear_limit + linear_intercept
        self._rating_floor = self.rating(linear_limit)  # the rating branch never releases less above l_lim
        # release bounds of each branch, with margins, for the branch checks of `day`
        self._linear_low = linear_slope * min_level + linear_intercept + _Q_MARGIN
        self._linear_high = self._linear_top - _Q_MARGIN
        self._rating_low = self._rating_floor + _Q_MARGIN
        self._rating_high = self.rating(max_level)

    # -- relations ---------------------------------------------------------------------------------

    def storage_to_level(self, storage: float) -> float:
        """Level (m) of a storage (m3): ``s / A + l_min``."""
        return storage / self.surface + self.min_level

    def level_to_storage(self, level: float) -> float:
        """Storage (m3) of a level (m): ``A (h - l_min)``."""
        return self.surface * (level - self.min_level)

    def rating(self, level: float) -> float:
        """Rating curve ``C_r (h - alpha)^beta`` (m3/s)."""
        return self.C_r * ((level - self.alpha) ** self.beta)

    def q_min(self, level: float, min_flow: float) -> float:
        """Smallest feasible release: 0 up to l_min, the day's minimum flow up to l_max, then the rating curve."""
        if level <= self.min_level:
            return 0.0
        if level <= self.max_level:
            return min_flow
        return self.rating(level)

    def q_max(self, level: float) -> float:
        """Largest feasible release: 0 up to l_min, ``k h + c`` up to l_lim, then the rating curve."""
        if level <= self.min_level:
            return 0.0
        if level <= self.linear_limit:
            return self.linear_slope * level + self.linear_intercept
        return self.rating(level)

    def release(self, level: float, decision: float, min_flow: float) -> float:
        """The decision clipped into ``[q_min, q_max]`` (the upper bound wins where they cross)."""
        return min(self.q_max(level), max(self.q_min(level, min_flow), decision))

    def safe_level(self, target: float) -> float:
        """A level from which ``q_max`` is at least ``target`` at every level up to l_max (inf if none).

        ``q_max`` is monotone within each branch but may drop where the linear branch meets the rating
        curve (148.810 vs 148.809 m3/s at l_lim by default), so the linear branch is used only for targets
        the rating curve also clears. The candidate is checked with the exact ``q_max`` expression.
        """
        k, c = self.linear_slope, self.linear_intercept
        if target <= min(self._linear_top, self._rating_floor):
            if k > 0:
                level = max((target - c) / k, self.min_level) + _MARGIN
            elif c >= target:
                level = self.min_level + _MARGIN
            else:
                level = self.linear_limit + _MARGIN
        elif target <= 0.0:
            level = self.linear_limit + _MARGIN
        else:
            level = max(self.alpha + (target / self.C_r) ** (1.0 / self.beta), self.linear_limit) + _MARGIN
        return level if self.q_max(level) >= target else math.inf

    # -- one day -----------------------------------------------------------------------------------

    def day(
        self, storage: float, decision: float, inflow: float, min_flow: float, evaporation: float
    ) -> tuple[float, float]:
        """Integrate one day; return (final storage, mean release).

        The result is bit-identical to evaluating ``release(level, decision, min_flow)`` in every
        sub-step and averaging with ``numpy.mean``. Within one day the level moves monotonically (the
        release is constant, or an increasing function of the level with ``dt q' / A < 1``), so when the
        first and last sub-steps lie inside one branch of the bounds (checked with margins far above
        rounding error), every sub-step does, and a branch-free loop computes the same numbers.

        Args:
            storage: Storage at the start of the day (m3).
            decision: The day's release decision (m3/s), already inside the action box.
            inflow: The day's inflow (m3/s).
            min_flow: The day's minimum environmental flow (m3/s).
            evaporation: The day's evaporation (m3/s).
        """
        area, lmin, lmax, llim = self.surface, self.min_level, self.max_level, self.linear_limit
        m = decision if decision > min_flow else min_flow  # max(q_min, decision) between l_min and l_max
        h = storage / area + lmin
        if h <= lmin:  # nothing can be released: storage rises by the net inflow
            s = storage
            step = self.dt * (inflow - 0.0 - evaporation)
            for _ in range(self.substeps - 1):
                s = s + step
            if s / area + lmin <= lmin:
                return s + step, 0.0
        elif h <= lmax:
            q = (
                self.linear_slope * h + self.linear_intercept
                if h <= llim
                else self.C_r * ((h - self.alpha) ** self.beta)
            )
            if q >= m:  # the decision is feasible: release m while it stays so
                s = storage
                step = self.dt * (inflow - m - evaporation)
                for _ in range(self.substeps - 1):
                    s = s + step
                h1 = s / area + lmin
                if lmin < h1 <= lmax:
                    q1 = (
                        self.linear_slope * h1 + self.linear_intercept
                        if h1 <= llim
                        else self.C_r * ((h1 - self.alpha) ** self.beta)
                    )
                    # q_max is monotone within a branch; across l_lim it may drop to the rating curve
                    if q1 >= m and ((h <= llim) == (h1 <= llim) or m <= self._rating_floor):
                        return s + step, self._constant_mean(m)
            elif h <= llim:
                out = self._linear_day(storage, q, m, inflow, evaporation)
                if out is not None:
                    return out
            else:
                out = self._rating_day(storage, q, m, inflow, evaporation, forced=False)
                if out is not None:
                    return out
        else:
            out = self._rating_day(storage, math.inf, m, inflow, evaporation, forced=True)
            if out is not None:
                return out
        return self._day_loop(storage, decision, inflow, min_flow, evaporation)

    def _constant_mean(self, m: float) -> float:
        if self.substeps == 24:
            return (3.0 * m) / 3.0  # numpy's pairwise mean of 24 equal values
        return np_sum([m] * self.substeps) / self.substeps

    def _linear_day(self, s: float, q0: float, m: float, inflow: float, evap: float) -> tuple[float, float] | None:
        """A day on the linear branch of q_max below the decision (release = k h + c), or None."""
        n = self.substeps
        k, c = self.linear_slope, self.linear_intercept
        if n < 8 or n > 128 or k <= 0 or not self._linear_low < q0 < m - _Q_MARGIN:
            return None
        area, lmin, dt = self.surface, self.min_level, self.dt
        r0 = r1 = r2 = r3 = r4 = r5 = r6 = r7 = 0.0
        r = q0
        for _ in range(n // 8):
            r = k * (s / area + lmin) + c
            s = s + dt * (inflow - r - evap)
            r0 += r
            r = k * (s / area + lmin) + c
            s = s + dt * (inflow - r - evap)
            r1 += r
            r = k * (s / area + lmin) + c
            s = s + dt * (inflow - r - evap)
            r2 += r
            r = k * (s / area + lmin) + c
            s = s + dt * (inflow - r - evap)
            r3 += r
            r = k * (s / area + lmin) + c
            s = s + dt * (inflow - r - evap)
            r4 += r
            r = k * (s / area + lmin) + c
            s = s + dt * (inflow - r - evap)
            r5 += r
            r = k * (s / area + lmin) + c
            s = s + dt * (inflow - r - evap)
            r6 += r
            r = k * (s / area + lmin) + c
            s = s + dt * (inflow - r - evap)
            r7 += r
        total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        for _ in range(n % 8):
            r = k * (s / area + lmin) + c
            s = s + dt * (inflow - r - evap)
            total += r
        if not self._linear_low < r < min(m, self._linear_high) - _Q_MARGIN:
            return None
        return s, total / n

    def _rating_day(
        self, s: float, q0: float, m: float, inflow: float, evap: float, forced: bool
    ) -> tuple[float, float] | None:
        """A day on the rating curve: above l_max (forced) or below the decision above l_lim; or None."""
        n = self.substeps
        if n < 8 or n > 128:
            return None
        area, lmin, dt, alpha, beta, cr = self.surface, self.min_level, self.dt, self.alpha, self.beta, self.C_r
        if not forced and not self._rating_low < q0 < min(m, self._rating_high) - _Q_MARGIN:
            return None
        r0 = r1 = r2 = r3 = r4 = r5 = r6 = r7 = 0.0
        r = q0
        for _ in range(n // 8):
            r = cr * ((s / area + lmin - alpha) ** beta)
            s = s + dt * (inflow - r - evap)
            r0 += r
            r = cr * ((s / area + lmin - alpha) ** beta)
            s = s + dt * (inflow - r - evap)
            r1 += r
            r = cr * ((s / area + lmin - alpha) ** beta)
            s = s + dt * (inflow - r - evap)
            r2 += r
            r = cr * ((s / area + lmin - alpha) ** beta)
            s = s + dt * (inflow - r - evap)
            r3 += r
            r = cr * ((s / area + lmin - alpha) ** beta)
            s = s + dt * (inflow - r - evap)
            r4 += r
            r = cr * ((s / area + lmin - alpha) ** beta)
            s = s + dt * (inflow - r - evap)
            r5 += r
            r = cr * ((s / area + lmin - alpha) ** beta)
            s = s + dt * (inflow - r - evap)
            r6 += r
            r = cr * ((s / area + lmin - alpha) ** beta)
            s = s + dt * (inflow - r - evap)
            r7 += r
        total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        for _ in range(n % 8):
            r = cr * ((s / area + lmin - alpha) ** beta)
            s = s + dt * (inflow - r - evap)
            total += r
        if forced:
            if not (r > self._rating_high + _Q_MARGIN and q0 > self._rating_high + _Q_MARGIN):
                return None
        elif not self._rating_low < r < min(m, self._rating_high) - _Q_MARGIN:
            return None
        return s, total / n

    def _day_loop(
        self, storage: float, decision: float, inflow: float, min_flow: float, evaporation: float
    ) -> tuple[float, float]:
        area, lmin, lmax, llim = self.surface, self.min_level, self.max_level, self.linear_limit
        k, c, alpha, beta, cr = self.linear_slope, self.linear_intercept, self.alpha, self.beta, self.C_r
        dt = self.dt
        m = decision if decision > min_flow else min_flow
        safe = self.safe_level(m)
        releases = []
        s = storage
        for _ in range(self.substeps):
            h = s / area + lmin
            if h <= lmin:
                r = 0.0
            elif h <= llim:
                q = k * h + c
                r = m if m < q else q
            elif h <= lmax:
                if h >= safe:
                    r = m
                else:
                    q = cr * ((h - alpha) ** beta)
                    r = m if m < q else q
            else:
                r = cr * ((h - alpha) ** beta)  # q_min = q_max: forced to the rating curve
            releases.append(r)
            s = s + dt * (inflow - r - evaporation)
        return s, np_sum(releases) / self.substeps

    def trace(
        self, storage: float, decision: float, inflow: float, min_flow: float, evaporation: float
    ) -> list[tuple[float, float]]:
        """The day sub-step by sub-step, straightforwardly: ``(storage before, release)`` of each sub-step.

        The reference for :meth:`day` (which must return the storage after the last sub-step and
        ``numpy.mean`` of the releases, bit for bit) and for the mass-balance tests.
        """
        out = []
        s = storage
        for _ in range(self.substeps):
            r = self.release(self.storage_to_level(s), decision, min_flow)
            out.append((s, r))
            s = s + self.dt * (inflow - r - evaporation)
        out.append((s, math.nan))
        return out

    # -- reachable levels --------------------------------------------------------------------------

    def level_range(self, start: float, max_inflow: float, evaporation_drop: float = 0.0) -> tuple[float, float]:
        """Bounds on every level reachable from ``start`` with inflow in ``[0, max_inflow]``.

        Upper: above ``h_top = max(l_max, rating^-1(max_inflow))`` the release exceeds any inflow, and one
        sub-step raises the level by at most ``dt * max_inflow / A``. Lower: from above l_min a sub-step
        lowers the level by at most ``dt (q_max(h) + e) / A``, which cannot cross l_min when
        ``dt * q_max' / A < 1`` (checked); below l_min nothing is released and only evaporation exceeding
        the inflow lowers it, by at most ``evaporation_drop`` (m) in an episode.
        """
        area, dt = self.surface, self.dt
        h_top = max(self.max_level, self.alpha + (max_inflow / self.C_r) ** (1.0 / self.beta))
        high = max(start, h_top + dt * max_inflow / area)
        # steepest q_max slope on [l_lim, high]: the rating curve's derivative at the top
        slope = max(self.linear_slope, self.C_r * self.beta * (high - self.alpha) ** (self.beta - 1.0))
        if dt * slope / area >= 1.0:
            msg = (
                f"`integration` = {self.substeps} sub-steps is too coarse for this lake: one sub-step can "
                f"overshoot the release bounds; use more sub-steps"
            )
            raise ValueError(msg)
        floor_flow = max(0.0, self.linear_slope * self.min_level + self.linear_intercept)
        low = min(start, self.min_level) - dt * floor_flow / area
        low -= evaporation_drop
        return low - 1e-9, high + 1e-9


def deficit_weight(day_index: int, smooth: bool) -> float:
    """Seasonal deficit weight of a 0-based day of year (reference expression, in the reference's order)."""
    if smooth:
        return 0.5 * (3 - math.cos(day_index * 2 * math.pi / 365))
    return 2.0 if 120 < day_index + 1 <= 243 else 1.0
