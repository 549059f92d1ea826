"""Frames of an ElevatorEnv episode (``render_mode="rgb_array"``).

Left, the shaft with its floors, the cabin at its height with its passengers (doors drawn open after
an opening at a floor), the queue waiting at each floor and this second's arrivals; right, the clock,
the passenger counts and the deliveries and balks of the episode so far.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gym4real.core.canvas import BLUE, GREEN, GREY, INK, LIGHT, ORANGE, RED, WHITE, Canvas

WIDTH, HEIGHT = 480, 320
SHAFT = (60.0, 40.0, 110.0, 296.0)  # the cabin's range: its top edge at the highest floor, bottom at the lowest
PLOT = (300.0, 150.0, 468.0, 280.0)
_SHOWN = 8  # people drawn per queue; more are counted in text


class ElevatorRenderer:
    """Draws the frames of one env; :meth:`record` keeps the counters of each second while rendering.

    Args:
        n_floors: Floors of the building.
        positions_per_floor: Cabin positions (steps) between two floors.
        goal: Index of the destination floor (0 = lowest).
        min_floor: Number of the lowest floor (for the labels).
        capacity: Passengers the cabin holds.
        duration: Seconds per episode.
    """

    def __init__(
        self, n_floors: int, positions_per_floor: int, goal: int, min_floor: int, capacity: int, duration: int
    ) -> None:
        self.n_floors, self.ppf, self.goal, self.capacity, self.duration = (
            n_floors,
            positions_per_floor,
            goal,
            capacity,
            duration,
        )
        self.top = (n_floors - 1) * positions_per_floor
        _, y0, _, y1 = SHAFT
        self.cabin_h = float(min(36, int((y1 - y0) / max(n_floors, 2))))
        self.radius = max(2.0, min(6.0, self.cabin_h / 5))
        self.delivered: list[int] = []
        self.turned_away: list[int] = []
        self.doors_open = False
        self._base = self._background(min_floor)

    def floor_y(self, position: float) -> float:
        """The pixel row of the cabin's floor at a position (steps from the lowest floor)."""
        _, y0, _, y1 = SHAFT
        return float(round(y1 - position / max(self.top, 1) * (y1 - y0 - self.cabin_h)))

    def _background(self, min_floor: int) -> Canvas:
        c = Canvas(WIDTH, HEIGHT)
        x0, y0, x1, y1 = SHAFT
        c.box((x0 - 2, y0 - 2, x1 + 2, y1 + 2), fill=LIGHT, outline=GREY)
        for floor in range(self.n_floors):
            y = self.floor_y(floor * self.ppf)
            c.line([(8, y), (x0 - 2, y)], INK, width=2)
            c.line([(x1 + 2, y), (280, y)], INK, width=2)
            name = f"F{floor + min_floor}"
            c.text((10, y - 14), name + (" exit" if floor == self.goal else ""), GREEN if floor == self.goal else INK)
        c.box(PLOT, outline=GREY)
        c.text((PLOT[0], PLOT[1] - 13), "so far:", GREY)
        c.text((PLOT[0] + 48, PLOT[1] - 13), "delivered", GREEN)
        c.text((PLOT[0] + 110, PLOT[1] - 13), "balked", RED)
        c.text((PLOT[2], PLOT[3] + 4), f"{self.duration} s", GREY, align="right")
        c.text((PLOT[0], PLOT[3] + 4), "0", GREY)
        return c

    def start(self) -> None:
        """Forget the previous episode."""
        self.delivered, self.turned_away, self.doors_open = [], [], False

    def record(self, delivered: int, turned_away: int, doors_open: bool) -> None:
        """Keep the counters after a second, and whether the doors opened at a floor in it."""
        self.delivered.append(delivered)
        self.turned_away.append(turned_away)
        self.doors_open = doors_open

    def _people(self, c: Canvas, x: float, y: float, count: int, fill: tuple[int, int, int], hollow: bool) -> float:
        """Draw ``count`` people in a row from ``x`` at baseline ``y``; return the x after them."""
        r = self.radius
        for _ in range(min(count, _SHOWN)):
            c.disc((x + r, y - r - 1), r, WHITE if hollow else fill, outline=fill)
            x += 2 * r + 3
        if count > _SHOWN:
            c.text((x, y - 12), f"+{count - _SHOWN}", fill)
            x += 18
        return x

    def frame(self, t: int, position: int, load: int, queues: Sequence[int], arrivals: dict[int, int]) -> np.ndarray:
        """The frame after ``t`` seconds.

        Args:
            t: Seconds elapsed.
            position: Cabin position (steps from the lowest floor).
            load: Passengers in the cabin.
            queues: People waiting at each floor (lowest first).
            arrivals: People who appeared this second, by floor index (they queue next second).
        """
        c = self._base.copy()
        delivered = self.delivered[-1] if self.delivered else 0
        balked = self.turned_away[-1] if self.turned_away else 0
        c.text((8, 6), "Elevator", INK, scale=2)
        c.text((120, 12), f"t = {t:4d} / {self.duration} s", INK)
        x0, _, x1, _ = SHAFT
        y = self.floor_y(position)
        at_floor = position % self.ppf == 0
        c.box((x0, y - self.cabin_h, x1, y), fill=WHITE, outline=BLUE, width=2)
        if self.doors_open and at_floor:  # the doors: a gap in the cabin's side facing the landing
            c.box((x1 - 1, y - self.cabin_h + 4, x1 + 1, y - 2), fill=GREEN)
            c.text((x1 + 6, y - self.cabin_h - 2), "open", GREEN)
        r = self.radius
        for i in range(load):
            per_row = max(1, int((x1 - x0 - 4) // (2 * r + 2)))
            cx = x0 + 4 + r + (i % per_row) * (2 * r + 2)
            cy = y - 3 - r - (i // per_row) * (2 * r + 2)
            c.disc((cx, cy), r, BLUE)
        c.text(((x0 + x1) / 2, y - self.cabin_h - 13), f"{load}/{self.capacity}", BLUE, align="center")
        for floor in range(self.n_floors):
            fy = self.floor_y(floor * self.ppf)
            x = self._people(c, x1 + 10, fy, queues[floor], ORANGE, hollow=False)
            if arrivals.get(floor):
                self._people(c, x + 4, fy, arrivals[floor], ORANGE, hollow=True)

        px = PLOT[0]
        lines = (
            (f"waiting      {sum(queues)}", ORANGE),
            (f"riding       {load}", BLUE),
            (f"delivered    {delivered}", GREEN),
            (f"balked       {balked}", RED),
        )
        for i, (text, hue) in enumerate(lines):
            c.text((px, 44 + 16 * i), text, hue, scale=1)
        self._people(c, px, 122, 1, ORANGE, hollow=False)
        c.text((px + 16, 110), "waiting", GREY)
        self._people(c, px + 70, 122, 1, ORANGE, hollow=True)
        c.text((px + 86, 110), "arriving", GREY)
        top = max(delivered, balked, 10)
        c.text((PLOT[0] - 4, PLOT[1]), str(top), GREY, align="right")
        c.series(PLOT, self.delivered, (0, top), self.duration, GREEN, width=2)
        c.series(PLOT, self.turned_away, (0, top), self.duration, RED, width=2)
        return c.array()
