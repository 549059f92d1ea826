"""Cycle counting for cyclic aging: a streaming ASTM E1049 rainflow counter and the reference's Dropflow.

Cycles are ``(range, mean, count, i_start, i_end)`` tuples: ``count`` is 1.0 for a full cycle and 0.5 for
a half cycle, ``i_start``/``i_end`` the indices of its two reversal points.

:class:`StreamingRainflow` (the corrected mode) does a constant amount of work per point (amortised):
it keeps only the residue stack of reversals, the damage of the closed cycles, and the damage of the
residue's half cycles as running sums, so the total cyclic damage is available after every point without
rescanning the history. :class:`Dropflow` reproduces the reference's incremental counter, defects included.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from itertools import pairwise

#: ``damage(range, mean, count, mean_temperature) -> float``: the damage of one (half) cycle.
DamageFn = Callable[[float, float, float, float], float]

Cycle = tuple[float, float, float, int, int]


def _no_damage(rng: float, mean: float, count: float, temp: float) -> float:
    return 0.0


class StreamingRainflow:
    """Streaming rainflow counter (ASTM E1049-85, section 5.4.4) with running damage sums.

    Each point carries a temperature; the mean temperature of a cycle is the mean over the points
    ``[i_start, i_end)``, taken from cumulative sums stored with the reversals (no history is kept).

    Args:
        damage: Damage of one (half) cycle; defaults to zero (pure counting).
        record: Keep the list of closed cycles in :attr:`cycles` (for tests and analysis).
    """

    def __init__(self, damage: DamageFn | None = None, record: bool = False) -> None:
        self.damage = damage or _no_damage
        self.record = record
        self.reset()

    def reset(self) -> None:
        """Forget every point and cycle."""
        # residue stack of reversals: [x, index, cumulative temperature before the index, half damage of
        # the pair (previous reversal, this one)]
        self._stack: list[list[float]] = []
        self._last: list[float] | None = None  # the latest point, a reversal-to-be
        self._direction = 0.0
        self._n = 0
        self._cum_temp = 0.0
        self._last_temp = 0.0
        self.closed_damage = 0.0
        self._residue_damage = 0.0
        self._tail_damage = 0.0
        self.cycles: list[Cycle] = []

    @property
    def residue_damage(self) -> float:
        """Damage of the open half cycles of the residue, the one ending at the latest point included."""
        return self._residue_damage + self._tail_damage

    @property
    def total_damage(self) -> float:
        """Closed cycles plus the residue's half cycles."""
        return self.closed_damage + self._residue_damage + self._tail_damage

    def _half(self, a: list[float], b: list[float]) -> float:
        span = b[1] - a[1]
        temp = (b[2] - a[2]) / span if span > 0 else self._last_temp
        return self.damage(abs(b[0] - a[0]), 0.5 * (a[0] + b[0]), 0.5, temp)

    def push(self, x: float, temperature: float = 298.15) -> None:
        """Add the next point of the series (a SoC value and the battery temperature at that point)."""
        point = [x, float(self._n), self._cum_temp, 0.0]
        self._n += 1
        self._cum_temp += temperature
        self._last_temp = temperature
        last = self._last
        if last is None:
            self._last = point
            return
        d = x - last[0]
        if d == 0.0:  # flat: not a peak or valley, only the temperature sums move on
            return
        if not self._stack:
            self._push_reversal(last)  # the first point is always a reversal
        elif d * self._direction < 0.0:
            self._push_reversal(last)
        self._direction = d
        self._last = point
        self._tail_damage = self._half(self._stack[-1], point)

    def _push_reversal(self, p: list[float]) -> None:
        stack = self._stack
        if stack:
            p[3] = self._half(stack[-1], p)
            self._residue_damage += p[3]
        stack.append(p)
        while len(stack) >= 3:
            c, b = stack[-1], stack[-2]
            a = stack[-3]
            if abs(c[0] - b[0]) < abs(b[0] - a[0]):
                break
            if len(stack) == 3:
                # Y contains the starting point: count it as a half cycle and discard the first point
                self.closed_damage += b[3]
                self._residue_damage -= b[3]
                if self.record:
                    self.cycles.append(_cycle(a, b, 0.5))
                del stack[0]
                stack[0][3] = 0.0
            else:
                # count Y as a full cycle and discard its two points
                full = 2.0 * b[3]
                self.closed_damage += full
                z = stack[-4]
                self._residue_damage -= b[3] + c[3] + a[3]
                if self.record:
                    self.cycles.append(_cycle(a, b, 1.0))
                del stack[-3:-1]
                c[3] = self._half(z, c)
                self._residue_damage += c[3]
        self._tail_damage = 0.0

    def residue(self) -> list[Cycle]:
        """The open half cycles: adjacent reversals of the residue and the latest point."""
        points = list(self._stack)
        if self._last is not None and (not points or self._last is not points[-1]):
            points.append(self._last)
        return [_cycle(a, b, 0.5) for a, b in pairwise(points)]


def _cycle(a: list[float], b: list[float], count: float) -> Cycle:
    return abs(b[0] - a[0]), 0.5 * (a[0] + b[0]), count, int(a[1]), int(b[1])


def count_cycles(series: Iterable[float]) -> list[Cycle]:
    """Rainflow-count a whole series (ASTM E1049-85): the closed cycles, then the residue's half cycles.

    The last point is processed as a reversal, as in the standard's batch procedure.
    """
    rf = StreamingRainflow(record=True)
    for x in series:
        rf.push(x)
    if rf._last is not None and rf._stack and rf._last is not rf._stack[-1]:
        rf._push_reversal(rf._last)
    return rf.cycles + [_cycle(a, b, 0.5) for a, b in pairwise(rf._stack)]


class Dropflow:
    """The reference's incremental rainflow counter ("Dropflow"), reproduced with its defects.

    ``add_point`` records a point; ``extract_new_cycles`` appends the transient stopper, extracts cycles
    (half cycles at the start point are emitted and *deleted*), then emits every remaining adjacent pair
    as a half cycle. The residue is rescanned at every call, and the stopper is not refreshed on flat
    segments.
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget every point."""
        self._reversals: list[tuple[int, float]] = []
        self._stopper: tuple[int, float] | tuple[()] = ()
        self._n = 0
        self._idx_last = 0
        self._x_last = 0.0
        self._x = 0.0
        self._d_last = 0.0

    def add_point(self, x: float, idx: int) -> None:
        """Add a point with its index."""
        if self._n == 0:
            self._x_last = x
            self._idx_last = 0
        elif self._n == 1:
            self._x = x
            self._d_last = x - self._x_last
            self._reversals.append((self._idx_last, self._x_last))
            self._idx_last = idx
        else:
            if x == self._x:
                self._idx_last = idx
                self._n += 1
                return
            d = x - self._x
            if self._d_last * d < 0:
                self._reversals.append((self._idx_last, self._x))
            self._x_last, self._x = self._x, x
            self._d_last = d
            self._idx_last = idx
            self._stopper = (idx, x)
        self._n += 1

    def extract_new_cycles(self) -> Iterator[Cycle]:
        """Yield the cycles extracted by this call, then the residue's half cycles."""
        rev = self._reversals
        if self._stopper:
            rev.append(self._stopper)  # type: ignore[arg-type]
        if not rev:
            return
        i = 0
        while i < len(rev) - 2:
            (i1, x1), (i2, x2), (_, x3) = rev[i], rev[i + 1], rev[i + 2]
            if abs(x3 - x2) < abs(x2 - x1):
                i += 1
            elif i == 0:
                yield abs(x1 - x2), 0.5 * (x1 + x2), 0.5, i1, i2
                rev.pop(0)
            else:
                yield abs(x1 - x2), 0.5 * (x1 + x2), 1.0, i1, i2
                del rev[i : i + 2]
        for (i1, x1), (i2, x2) in pairwise(rev):
            yield abs(x1 - x2), 0.5 * (x1 + x2), 0.5, i1, i2
        if self._stopper and rev[-1] == self._stopper:
            rev.pop()
