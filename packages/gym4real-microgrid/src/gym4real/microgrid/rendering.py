"""Frames of a MicrogridEnv episode (``render_mode="rgb_array"``).

Left, the battery's state of charge (with its window), state of health (with the end of life) and
temperature; right, the mean power flows of the last step between PV, the household, the battery and
the grid, with arrows as thick as the flow; under them the buy and sell prices of the coming hour,
the cumulative trading profit and degradation cost, and the state of charge over the last week.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from gym4real.core.canvas import BLUE, GREEN, GREY, INK, LIGHT, ORANGE, PURPLE, RED, Canvas, Colour

WIDTH, HEIGHT = 480, 320
_NODES = {"PV": (230.0, 66.0), "home": (420.0, 66.0), "battery": (230.0, 190.0), "grid": (420.0, 190.0)}
_BUS = (325.0, 128.0)
_TRACE = (196.0, 266.0, 468.0, 306.0)
_WEEK = 168  # hours of the state-of-charge trace
_FULL_ARROW_W = 3000.0  # a flow of this power (W) gets the widest arrow
_TEMPERATURE_C = (0.0, 60.0)  # the thermometer's range (deg C)
SOC_GAUGE = (18.0, 60.0, 42.0, 250.0)


class MicrogridRenderer:
    """Draws the frames of one env; :meth:`record` keeps what a step did while rendering.

    Args:
        soc_min: Lower end of the SoC window.
        soc_max: Upper end of the SoC window.
        eol_soh: State of health at end of life.
        step_hours: Hours per data step.
    """

    def __init__(self, soc_min: float, soc_max: float, eol_soh: float, step_hours: float) -> None:
        self.soc_min, self.soc_max, self.eol_soh, self.step_hours = soc_min, soc_max, eol_soh, step_hours
        self.start(0.0)
        self._base = self._background()

    def _background(self) -> Canvas:
        c = Canvas(WIDTH, HEIGHT)
        for name, (x, y) in _NODES.items():
            c.box((x - 34, y - 14, x + 34, y + 14), fill=LIGHT, outline=GREY)
            c.text((x, y - 5), name, INK, align="center")
        c.disc(_BUS, 5, INK)
        c.box(_TRACE, outline=GREY)
        c.text((_TRACE[0], _TRACE[1] - 13), f"SoC, last {_WEEK // 24} days", GREY)
        c.text((_TRACE[0] - 3, _TRACE[1] - 2), "1", GREY, align="right")
        c.text((_TRACE[0] - 3, _TRACE[3] - 9), "0", GREY, align="right")
        for i, name in enumerate(("SoC", "SoH", "temp")):
            c.text((30 + 50 * i, 262), name, INK, align="center")
        return c

    def start(self, soc: float) -> None:
        """Forget the previous episode; the battery starts at ``soc``."""
        self.profit = self.degradation = 0.0
        self.power: dict[str, float] = {}
        self.socs: deque[float] = deque([soc], maxlen=_WEEK + 1)
        self._iterations = 0

    def record(self, energy: dict[str, float], trading: float, degradation: float, soc: float, iterations: int) -> None:
        """Keep a step: its energies (Wh), trading and degradation (EUR), the SoC after it, data steps so far."""
        hours = (iterations - self._iterations) * self.step_hours
        self._iterations = iterations
        self.power = {k: v / hours for k, v in energy.items()} if hours > 0 else {}
        self.profit += trading
        self.degradation += degradation
        self.socs.append(soc)

    def _flow(self, c: Canvas, node: str, inward: float, outward: float, colour: Colour) -> None:
        """The arrow between the bus and a node: ``inward`` W towards the bus, ``outward`` W away from it."""
        power = outward - inward
        x, y = _NODES[node]
        end = (x + (-30 if x > _BUS[0] else 30), y + (-10 if y > _BUS[1] else 10))
        if abs(power) >= 1.0:
            width = 1 + round(7 * min(abs(power) / _FULL_ARROW_W, 1.0))
            start, stop = (_BUS, end) if power > 0 else (end, _BUS)
            c.arrow(start, stop, colour, width)
        label = f"{abs(power) / 1000:.2f} kW"
        c.text((x, y + (18 if y > _BUS[1] else -28)), label, colour if abs(power) >= 1.0 else GREY, align="center")

    def frame(
        self, profile: str, seconds: float, soc: float, soh: float, temperature: float, ask: float, bid: float
    ) -> np.ndarray:
        """The frame before the hour that starts ``seconds`` after the first data row.

        Args:
            profile: The household's demand profile.
            seconds: Time of the coming hour from the first data row (s).
            soc: State of charge.
            soh: State of health.
            temperature: Battery temperature (K).
            ask: Buy price of the coming hour (EUR/Wh).
            bid: Sell price of the coming hour (EUR/Wh).
        """
        c = self._base.copy()
        day, hour = int(seconds // 86400) + 1, int(seconds % 86400 // 3600)
        c.text((8, 6), "Microgrid", INK, scale=2)
        c.text((130, 12), f"household {profile}  day {day:3d}  {hour:02d}:00", INK)

        window = ((self.soc_min, ORANGE), (self.soc_max, ORANGE))
        c.gauge(SOC_GAUGE, soc, GREEN, marks=window)
        c.text((30, 276), f"{100 * soc:.0f}%", INK, align="center")
        c.gauge((68.0, 60.0, 92.0, 250.0), soh, PURPLE, marks=((self.eol_soh, RED),))
        c.text((80, 276), f"{100 * soh:.1f}%", INK, align="center")
        celsius = temperature - 273.15
        low, high = _TEMPERATURE_C
        c.gauge((118.0, 60.0, 142.0, 250.0), (celsius - low) / (high - low), RED)
        c.text((130, 276), f"{celsius:.1f}", INK, align="center")
        c.text((130, 288), "deg C", GREY, align="center")
        c.text((8, 42), "battery", GREY)

        p = self.power
        if p:
            self._flow(c, "PV", p["pv"], 0.0, ORANGE)
            self._flow(c, "home", 0.0, p["demand"], INK)
            self._flow(c, "battery", p["from_battery"], p["to_battery"], GREEN)
            self._flow(c, "grid", p["bought"], p["sold"], BLUE)
        c.text((196, 222), f"buy  {1000 * ask:.3f} EUR/kWh", BLUE)
        c.text((196, 234), f"sell {1000 * bid:.3f} EUR/kWh", BLUE)
        c.text((468, 222), f"profit {self.profit:+9.2f} EUR", GREEN if self.profit >= 0 else RED, align="right")
        c.text((468, 234), f"degradation {self.degradation:+8.2f} EUR", RED, align="right")
        socs = list(self.socs)
        c.series(_TRACE, socs, (0.0, 1.0), _WEEK + 1, GREEN, width=2)
        return c.array()
