"""The Richardson load model's days as compiled loops (numba), drawing from Python's own random stream.

``richardsonpy`` (the tool of :mod:`gym4real.microgrid.standin`) simulates every minute of every light bulb
and appliance of a household in Python: about 21 s per household-year. :func:`simulate_year` runs its
lighting (``run_lighting_simulation``) and appliance (``run_application_simulation``) rules of version
0.2.3 as written, on the same inputs, drawing the same numbers from the same generator: the Mersenne Twister
of Python's :mod:`random` (:func:`random_float`, :func:`gauss`), whose state it takes over
(:func:`random_state`) and carries through the year in the order richardsonpy draws. Every floating-point
operation is the one richardsonpy evaluates, in its order (a sum over bulbs and appliances in their order,
``math.log``/``cos``/``sin``/``pow`` from the same C library), so a household is bit for bit richardsonpy's.

Only the stand-in's configuration is covered: no electric space or water heating (richardsonpy's
``prev_heat_dev``; :func:`simulate_year` refuses a household that owns such an appliance), the default
lighting model, no seasonal lighting modification and no normalisation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_N = 624  # Mersenne Twister state words (CPython's _randommodule.c)
_M = 397
_MATRIX_A = 0x9908B0DF
_UPPER = 0x80000000
_LOWER = 0x7FFFFFFF
_WORD = 0xFFFFFFFF
_TWOPI = 2.0 * math.pi

#: richardsonpy's appliance rows that heat space or water (``prev_heat_dev`` removes them).
HEATING = (29, 30, 31, 32)
#: Appliances with a drawn cycle length (richardsonpy's TV viewing time, minutes).
_TVS = (14, 15, 16)
_WASHING_MACHINE = 26
_WASHER_DRYER = 27
#: Activity profiles of richardsonpy's appliance table (column ``Activity use profile``).
_ACTIVE_OCCUPANCY = 6
_LEVEL = 7
_CUSTOM = 8
_LAUNDRY = 2


def random_state(state: tuple[int, tuple[int, ...], float | None]) -> tuple[np.ndarray, np.ndarray]:
    """The generator state of :func:`random.getstate` as the arrays :func:`simulate_year` draws from.

    Returns:
        ``words`` (the 624 state words and the position of the next one, int64) and ``cached`` (Python's
        pending second normal deviate of :func:`random.gauss`: ``[1, z]``, or ``[0, 0]`` when none).
    """
    _, words, pending = state
    cached = np.array([0.0, 0.0] if pending is None else [1.0, pending])
    return np.array(words, dtype=np.int64), cached


@njit(cache=True)
def _next_word(words: np.ndarray) -> int:
    """The generator's next 32-bit output (``genrand_uint32``); ``words[624]`` is the position."""
    if words[_N] >= _N:
        for k in range(_N):
            y = (words[k] & _UPPER) | (words[(k + 1) % _N] & _LOWER)
            words[k] = words[(k + _M) % _N] ^ (y >> 1) ^ (_MATRIX_A if y & 1 else 0)
        words[_N] = 0
    y = words[words[_N]]
    words[_N] += 1
    y ^= y >> 11
    y ^= (y << 7) & 0x9D2C5680
    y ^= (y << 15) & 0xEFC60000
    y ^= y >> 18
    return y & _WORD


@njit(cache=True)
def random_float(words: np.ndarray) -> float:
    """:func:`random.random`: 53 random bits in [0, 1)."""
    a = _next_word(words) >> 5
    b = _next_word(words) >> 6
    return (a * 67108864.0 + b) * (1.0 / 9007199254740992.0)


@njit(cache=True)
def gauss(words: np.ndarray, cached: np.ndarray, mu: float, sigma: float) -> float:
    """:func:`random.gauss`: a normal deviate, in pairs (the second one is kept in ``cached`` for the next call)."""
    if cached[0] != 0.0:
        z = cached[1]
        cached[0] = 0.0
    else:
        x2pi = random_float(words) * _TWOPI
        g2rad = math.sqrt(-2.0 * math.log(1.0 - random_float(words)))
        z = math.cos(x2pi) * g2rad
        cached[0] = 1.0
        cached[1] = math.sin(x2pi) * g2rad
    return mu + z * sigma


@njit(cache=True)
def _round_half_even(x: float) -> float:
    """Python's ``round(x)``: the nearest integer, ties to even."""
    r = float(math.floor(x))
    rest = x - r
    if rest > 0.5 or (rest == 0.5 and r % 2.0 != 0.0):
        r += 1.0
    return r


@njit(cache=True)
def _lighting_day(
    words: np.ndarray,
    cached: np.ndarray,
    occupancy: np.ndarray,
    irradiance: np.ndarray,
    bulbs: np.ndarray,
    lighting: np.ndarray,
    effective: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    out: np.ndarray,
) -> None:
    """Add one day's lighting power (W per minute) to ``out``, bulb by bulb in their order.

    ``lighting`` holds the model's irradiance threshold (mean, standard deviation, W/m2) and calibration
    scalar; ``effective`` the effective occupancy per number of active occupants; ``lower``/``upper`` the
    bounds of the nine equally likely switch-on durations (minutes).
    """
    threshold = gauss(words, cached, lighting[0], lighting[1])
    durations = len(lower)
    for bulb in range(len(bulbs)):
        rating = bulbs[bulb]
        weighting = lighting[2] * -math.log(random_float(words))
        t = 0
        while t < 1440:
            low = irradiance[t] < threshold or random_float(words) < 0.05
            if low and random_float(words) < effective[occupancy[t // 10]] * weighting:
                r1 = random_float(words)
                duration = 0.0
                for j in range(1, durations + 1):
                    if r1 < j / durations:
                        duration = random_float(words) * (upper[j - 1] - lower[j - 1]) + lower[j - 1]
                        break
                for _ in range(int(duration)):
                    if t > 1439 or occupancy[t // 10] == 0:
                        break
                    out[t] += rating
                    t += 1
            else:
                t += 1


@njit(cache=True)
def _appliance_power(appliance: int, left: float, standby: float, rated: float) -> float:
    """The power (W) of a running appliance with ``left`` minutes of its cycle to go (washing cycles vary)."""
    if appliance != _WASHING_MACHINE and appliance != _WASHER_DRYER:
        return rated
    minute = (138.0 if appliance == _WASHING_MACHINE else 198.0) - left + 1.0
    if 0.0 < minute <= 8.0:
        return 73.0  # start-up and fill
    if minute <= 29.0:
        return 2056.0  # heating
    if minute <= 92.0:
        return 73.0  # wash, drain and spin
    if minute <= 94.0:
        return 250.0  # rinse
    if minute <= 105.0:
        return 73.0
    if minute <= 107.0:
        return 250.0
    if minute <= 118.0:
        return 73.0
    if minute <= 120.0:
        return 250.0
    if minute <= 131.0:
        return 73.0
    if minute <= 133.0:
        return 250.0
    if minute <= 138.0:
        return 568.0  # fast spin
    if minute <= 198.0:
        return 2500.0  # drying
    return standby


@njit(cache=True)
def _cycle_length(words: np.ndarray, appliance: int, mean: float) -> float:
    """Minutes of a cycle: the table's mean, or a drawn TV viewing time (Python's ``round``)."""
    if appliance == _TVS[0] or appliance == _TVS[1] or appliance == _TVS[2]:
        return _round_half_even(70.0 * (-math.log(1 - random_float(words))) ** 1.1)
    return mean


@njit(cache=True)
def _appliances_day(
    words: np.ndarray,
    cached: np.ndarray,
    occupancy: np.ndarray,
    table: np.ndarray,
    scalars: np.ndarray,
    activity: np.ndarray,
    out: np.ndarray,
) -> None:
    """Add one day's appliance power (W per minute) to ``out``, appliance by appliance in the table's order.

    ``table`` is richardsonpy's appliance table (rows: appliances; columns from ``Has appliance?``), with
    its calibration scalars ``scalars``; ``activity`` the day's activity statistics (weekday or weekend).
    """
    for i in range(table.shape[0]):
        if table[i, 0] == 0:
            continue
        mean_length, rated, standby = table[i, 3], table[i, 4], table[i, 5]
        delay, profile = table[i, 6], table[i, 8]
        left = 0.0
        resting = random_float(words) * delay * 2
        rated = gauss(words, cached, rated, rated / 10)
        for minute in range(1440):
            power = standby
            ten = minute // 10
            active = occupancy[ten]
            if left <= 0 and resting > 0:
                resting -= 1
            elif left <= 0:
                if (active > 0 and profile != _CUSTOM) or profile == _LEVEL:
                    probability = 1.0
                    if profile < _ACTIVE_OCCUPANCY:
                        probability = activity[int(5 * active + profile), ten + 2]
                    if random_float(words) < scalars[i] * probability:
                        left = _cycle_length(words, i, mean_length)
                        power = _appliance_power(i, left, standby, rated)
                        left -= 1
                        resting = delay
            elif not (active == 0 and profile != _LEVEL and profile != _LAUNDRY and profile != _CUSTOM):
                power = _appliance_power(i, left, standby, rated)
                left -= 1
            out[minute] += power


@njit(cache=True)
def simulate_year(
    words: np.ndarray,
    cached: np.ndarray,
    occupancy: np.ndarray,
    irradiance: np.ndarray,
    first_weekday: int,
    bulbs: np.ndarray,
    lighting: np.ndarray,
    effective: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    table: np.ndarray,
    scalars: np.ndarray,
    activity: np.ndarray,
) -> np.ndarray:
    """One household's electric power (W), one value per minute of ``irradiance.shape[0]`` days.

    Each day is richardsonpy's ``ElectricityProfile.power_sim``: lighting, then appliances, drawing from
    ``words``/``cached`` (:func:`random_state`, advanced in place); the day's power is appliances plus
    lighting.

    Args:
        words: The generator's state words and position (:func:`random_state`).
        cached: The generator's pending normal deviate (:func:`random_state`).
        occupancy: Active occupants per ten minutes (144 a day), from richardsonpy's ``Occupancy``.
        irradiance: Global irradiance (W/m2) per day and minute as richardsonpy interpolates it.
        first_weekday: 1 (Monday) .. 7 (Sunday).
        bulbs: Rating (W) of each light bulb.
        lighting: Irradiance threshold (mean, standard deviation; W/m2) and calibration scalar of lighting.
        effective: Effective occupancy (sharing of lights) per number of active occupants.
        lower: Shortest switch-on duration (minutes) of each of the nine duration bands.
        upper: Longest switch-on duration (minutes) of each band.
        table: richardsonpy's appliance table (rows: appliances; columns from ``Has appliance?``).
        scalars: The appliances' calibration scalars (richardsonpy's ``Appliances.calib_scalar``).
        activity: Activity statistics, ``activity[0]`` weekdays and ``activity[1]`` weekends.

    Raises:
        ValueError: The household owns an electric space or water heater (not covered).
    """
    for i in HEATING:
        if table[i, 0] != 0:
            raise ValueError("electric space and water heating is not covered (richardsonpy's prev_heat_dev)")
    days = irradiance.shape[0]
    power = np.empty(days * 1440)
    light = np.empty(1440)
    appliances = np.empty(1440)
    for day in range(days):
        weekend = (day + first_weekday) % 7 in (0, 6)
        light[:] = 0.0
        appliances[:] = 0.0
        occupants = occupancy[144 * day : 144 * (day + 1)]
        _lighting_day(words, cached, occupants, irradiance[day], bulbs, lighting, effective, lower, upper, light)
        _appliances_day(words, cached, occupants, table, scalars, activity[1 if weekend else 0], appliances)
        power[1440 * day : 1440 * (day + 1)] = appliances + light
    return power
