"""Frames of a DamEnv episode (``render_mode="rgb_array"``).

Left, the lake level on a gauge against the flood and starving thresholds; right, the level trace of
the episode so far with the same thresholds, and under it the daily inflow, release and demand traces
with today's values.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gym4real.core.canvas import BLUE, GREEN, GREY, INK, LIGHT, ORANGE, RED, WATER, Canvas

WIDTH, HEIGHT = 480, 320
GAUGE = (24.0, 44.0, 60.0, 280.0)
LEVELS = (120.0, 44.0, 468.0, 150.0)
FLOWS = (120.0, 182.0, 468.0, 280.0)
#: Where the frame's day and step label starts.
LABEL_AT = (190.0, 12.0)


def day_label(day: int, t: int) -> str:
    """The day a state is at: ``day   1 start`` before the first day, else ``day 365 end`` (the day just simulated).

    Args:
        day: 1-based day of year: of the first day when ``t`` is 0, else of the last day simulated.
        t: Days simulated so far.
    """
    return f"day {day:3d} {'end' if t else 'start'}"


class DamRenderer:
    """Draws the frames of one env; :meth:`record` keeps each day's release while rendering.

    Args:
        horizon: Days per episode (the traces' width).
        flood_level: Level above which a day counts as overflow (m).
        starving_level: Level below which a day counts as starving (m).
    """

    def __init__(self, horizon: int, flood_level: float, starving_level: float) -> None:
        self.horizon = horizon
        self.flood, self.starving = flood_level, starving_level
        self.span = (starving_level - 0.35, flood_level + 0.6)  # the levels the gauge and the trace show
        self.releases: list[float] = []
        self._base = self._background()

    def _background(self) -> Canvas:
        c = Canvas(WIDTH, HEIGHT)
        lo, hi = self.span
        for box in (LEVELS, FLOWS):
            c.box(box, outline=GREY)
        x0, y0, x1, y1 = LEVELS
        for level, colour, name in ((self.flood, RED, "flood"), (self.starving, ORANGE, "starving")):
            y = y1 - (level - lo) / (hi - lo) * (y1 - y0)
            c.dashed(y, x0, x1, colour)
            c.text((x1 - 2, y - 12 if level > lo + 0.2 else y + 2), f"{name} {level:+.2f} m", colour, align="right")
        c.text((x0 - 4, y0), f"{hi:+.1f}", GREY, align="right")
        c.text((x0 - 4, y1 - 10), f"{lo:+.1f}", GREY, align="right")
        c.text((x0, y0 - 13), "level (m)", GREY)
        c.text((FLOWS[0], FLOWS[1] - 13), "flows (m3/s)", GREY)
        c.text(((GAUGE[0] + GAUGE[2]) / 2, GAUGE[3] + 6), "lake", INK, align="center")
        return c

    def start(self) -> None:
        """Forget the previous episode's releases."""
        self.releases = []

    def record(self, release: float) -> None:
        """Keep the day's mean release (m3/s)."""
        self.releases.append(release)

    def frame(
        self,
        year: int,
        day: int,
        levels: Sequence[float],
        inflow: Sequence[float],
        demand: Sequence[float],
    ) -> np.ndarray:
        """The frame after ``len(levels) - 1`` days.

        Args:
            year: The episode's year.
            day: 1-based day of year: of the first day before any is simulated, else of the last day simulated.
            levels: Level at the start and after each day so far (m).
            inflow: The episode's daily inflow (m3/s), all days.
            demand: The episode's daily demand (m3/s), all days.
        """
        c = self._base.copy()
        t = len(levels) - 1
        level = levels[-1]
        lo, hi = self.span
        flood_days = sum(1 for v in levels[1:] if v > self.flood)
        starving_days = sum(1 for v in levels[1:] if v < self.starving)
        c.text((8, 6), f"Lake Como {year}", INK, scale=2)
        c.text(LABEL_AT, f"{day_label(day, t)}  (step {t}/{self.horizon})", INK)
        c.text((WIDTH - 8, 8), f"flood days {flood_days}", RED if flood_days else GREY, align="right")
        c.text((WIDTH - 8, 20), f"starving days {starving_days}", ORANGE if starving_days else GREY, align="right")

        def height(v: float) -> float:
            return (v - lo) / (hi - lo)

        colour = RED if level > self.flood else ORANGE if level < self.starving else WATER
        c.gauge(GAUGE, height(level), colour, marks=((height(self.flood), RED), (height(self.starving), ORANGE)))
        c.text(((GAUGE[0] + GAUGE[2]) / 2, GAUGE[3] + 18), f"{level:+.2f} m", INK, align="center")

        h = self.horizon  # the level trace has h + 1 points; day k's flows sit under the level after it
        x0, _, x1, _ = FLOWS
        x = x0 + t / h * (x1 - x0)
        c.line([(x, LEVELS[1]), (x, FLOWS[3])], LIGHT)
        c.series(LEVELS, levels, self.span, h + 1, BLUE, width=2)
        q_max = 1.05 * max(max(inflow), max(demand), max(self.releases, default=0.0), 1.0)
        c.text((FLOWS[0] - 4, FLOWS[1]), f"{q_max:.0f}", GREY, align="right")
        c.text((FLOWS[0] - 4, FLOWS[3] - 10), "0", GREY, align="right")
        days = (x0 + (x1 - x0) / h, *FLOWS[1:])
        for values, hue in ((inflow[:t], WATER), (demand[:t], ORANGE), (self.releases[:t], GREEN)):
            c.series(days, values, (0.0, q_max), h, hue, width=1 if hue == WATER else 2)
        today = t - 1
        if today >= 0:
            legend = (
                (f"inflow {inflow[today]:6.1f}", WATER),
                (f"release {self.releases[today]:6.1f}", GREEN),
                (f"demand {demand[today]:6.1f} m3/s", ORANGE),
            )
            x = FLOWS[0]
            for text, hue in legend:
                c.text((x, FLOWS[3] + 8), text, hue)
                x += (len(text) + 2) * 6
        return c.array()
