"""Bolun aging model: calendar plus cyclic aging, SEI-film degradation.

Degradation ``deg = 1 - alpha * exp(-beta * f_d) - (1 - alpha) * exp(-f_d)`` of the damage ``f_d``,
the sum of calendar aging and of the cycles' damage. Stress functions (aging YAML ``stress_models``):

* time ``k_t * t``; soc ``exp(k_soc * (soc - soc_ref))``;
* temperature ``exp(k_temp * (T - T_ref) * T_ref / T)`` (kelvin);
* dod_bolun ``1 / (k_delta1 * DoD ** k_delta2 + k_delta3)`` per cycle (0 for DoD = 0).

:class:`BolunAging` by default integrates the calendar stress rate step by step (equal to the reference's
``k_t * t * S(mean SoC) * S(mean T)`` under constant conditions) and counts cycles with the streaming
rainflow counter, keeping the residue's half cycles: the damage never decreases, so the state of health
never increases. Its switches reproduce the reference instead: running means over the episode, the previous
step's elapsed time, and the Dropflow counter whose dropped half cycles make SoH non-monotone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from gym4real.microgrid.rainflow import Dropflow, StreamingRainflow

CALENDAR_FACTORS = ("time", "soc", "temperature")
CYCLIC_FACTORS = ("soc", "temperature", "dod_bolun")


@dataclass(frozen=True)
class AgingParams:
    """Constants of the Bolun model (``models/aging.yaml``)."""

    alpha_sei: float = 0.0575
    beta_sei: float = 121.0
    calendar: tuple[str, ...] = CALENDAR_FACTORS
    cyclic: tuple[str, ...] = CYCLIC_FACTORS
    k_t: float = 4.14e-10
    k_soc: float = 1.04
    soc_ref: float = 0.5
    k_temp: float = 0.0693
    temp_ref: float = 298.15
    k_delta1: float = 1.4e5
    k_delta2: float = -0.501
    k_delta3: float = -1.23e5

    def float32(self) -> AgingParams:
        """The constants the reference casts to float32 (k_t, k_temp, k_delta1..3), rounded likewise."""

        def f32(v: float) -> float:
            return float(np.float32(v))

        return replace(
            self,
            k_t=f32(self.k_t),
            k_temp=f32(self.k_temp),
            k_delta1=f32(self.k_delta1),
            k_delta2=f32(self.k_delta2),
            k_delta3=f32(self.k_delta3),
        )

    def soc_stress(self, soc: float) -> float:
        """SoC stress factor."""
        return math.exp(self.k_soc * (soc - self.soc_ref))

    def temperature_stress(self, temp: float) -> float:
        """Temperature stress factor (temp in kelvin)."""
        return math.exp(self.k_temp * (temp - self.temp_ref) * (self.temp_ref / temp))

    def dod_stress(self, dod: float) -> float:
        """Depth-of-discharge stress of one full cycle."""
        if dod <= 0.0:
            return 0.0
        return 1.0 / (self.k_delta1 * dod**self.k_delta2 + self.k_delta3)

    def cycle_damage(self, dod: float, mean_soc: float, count: float, mean_temp: float) -> float:
        """Damage of one (half) cycle with the configured cyclic stress factors."""
        value = count
        for factor in self.cyclic:
            if factor == "dod_bolun":
                value *= self.dod_stress(dod)
            elif factor == "soc":
                value *= self.soc_stress(mean_soc)
            else:
                value *= self.temperature_stress(mean_temp)
        return value

    def calendar_stress(self, soc: float, temp: float) -> float:
        """Product of the configured calendar factors other than time."""
        value = 1.0
        if "soc" in self.calendar:
            value *= self.soc_stress(soc)
        if "temperature" in self.calendar:
            value *= self.temperature_stress(temp)
        return value

    def degradation(self, f_d: float) -> float:
        """SEI-film degradation of a damage ``f_d``."""
        a = self.alpha_sei
        return 1.0 - a * math.exp(-self.beta_sei * f_d) - (1.0 - a) * math.exp(-f_d)


class BolunAging:
    """Calendar plus cyclic aging of one battery, step by step.

    Args:
        params: The model constants.
        calendar_time: Integrate the calendar stress rate over each step (corrected); False: the
            reference's ``k_t * t_prev * S(mean SoC) * S(mean T)`` with ``t_prev`` the elapsed time of
            the previous step (-1 s at the first step) and running means over the episode.
        standard_rainflow: Streaming ASTM rainflow from the initial state, the residue's half cycles
            kept, damage never decreasing (corrected); False: the reference's Dropflow counter from the
            first step, constants cast to float32, half cycles at the start point dropped.
    """

    def __init__(self, params: AgingParams, *, calendar_time: bool = True, standard_rainflow: bool = True) -> None:
        self.params = params if standard_rainflow else params.float32()
        self.calendar_time = calendar_time
        self.standard_rainflow = standard_rainflow
        self._timed = "time" in params.calendar
        self.rainflow = StreamingRainflow(damage=self.params.cycle_damage)
        self.dropflow = Dropflow()
        self.reset(0.5, params.temp_ref)

    def reset(self, soc: float, temp: float) -> None:
        """Start from a new battery at ``(soc, temp)``."""
        self.k = 0
        self.calendar = 0.0
        self.cyclic = 0.0
        self.damage = 0.0
        self.deg = 0.0
        self._mean_soc = 0.0
        self._mean_temp = 0.0
        self._f_cyc = 0.0
        self._cum_temp = [0.0]
        self.rainflow.reset()
        self.dropflow.reset()
        if self.standard_rainflow:
            self.rainflow.push(soc, temp)  # the initial state is the first point of the cycle counter

    def step(self, soc0: float, soc1: float, temp0: float, temp1: float, dt: float, elapsed: float) -> float:
        """Age over one step from ``(soc0, temp0)`` to ``(soc1, temp1)``; return the degradation.

        Args:
            soc0: SoC at the start of the step.
            soc1: SoC at the end of the step.
            temp0: Battery temperature (K) at the start of the step.
            temp1: Battery temperature (K) at the end of the step.
            dt: Step length (s).
            elapsed: Time (s) from the reset to the start of the step.
        """
        p = self.params
        k = self.k
        self.k = n = k + 1
        if self.calendar_time:
            if self._timed:
                self.calendar += p.k_t * dt * p.calendar_stress(0.5 * (soc0 + soc1), 0.5 * (temp0 + temp1))
        else:
            self._mean_soc = (soc1 + self._mean_soc * (n - 1)) / n
            self._mean_temp = (temp1 + self._mean_temp * (n - 1)) / n
            f_cal = 1.0
            for factor in p.calendar:
                if factor == "time":
                    # float32, as the reference's product of a float32 constant and an int time (NumPy 2)
                    f_cal *= float(np.float32(p.k_t * (elapsed - dt if k else -1.0)))
                elif factor == "soc":
                    f_cal *= p.soc_stress(self._mean_soc)
                else:
                    f_cal *= p.temperature_stress(self._mean_temp)
            self.calendar = f_cal
        if self.standard_rainflow:
            self.rainflow.push(soc1, temp1)
            self.cyclic = self.rainflow.total_damage
            f_d = self.calendar + self.cyclic
            if f_d > self.damage:
                self.damage = f_d
                self.deg = p.degradation(f_d)
            return self.deg
        self.cyclic = self._dropflow_step(soc1, temp1, k)
        self.damage = self.calendar + self.cyclic
        self.deg = min(max(p.degradation(self.damage), 0.0), 1.0)
        return self.deg

    def _dropflow_step(self, soc: float, temp: float, k: int) -> float:
        p = self.params
        self.dropflow.add_point(soc, k)
        cum = self._cum_temp
        cum.append(cum[-1] + temp)
        cycles = list(self.dropflow.extract_new_cycles())
        cut = len(cycles)
        while cut and cycles[cut - 1][2] == 0.5:  # trailing half cycles count for this step only
            cut -= 1
        incomplete = 0.0
        for rng, mean, count, i0, i1 in cycles[cut:]:
            incomplete += p.cycle_damage(rng, mean, count, _mean_over(cum, i0, i1))
        for rng, mean, count, i0, i1 in cycles[:cut]:
            self._f_cyc += p.cycle_damage(rng, mean, count, _mean_over(cum, i0, i1))
        return self._f_cyc + incomplete


def _mean_over(cum: list[float], i: int, j: int) -> float:
    """Mean of the values ``[i, j)`` from their cumulative sums (NaN when empty, as numpy's mean)."""
    return (cum[j] - cum[i]) / (j - i) if j > i else math.nan
