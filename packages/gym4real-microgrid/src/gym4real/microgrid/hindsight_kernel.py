"""The hindsight planner's dynamic programme over the battery's state of charge, one compiled loop (numba).

:func:`solve` maximises, over the paths of a SoC grid, the sum of each hour's transition reward
:func:`transition` (the planner's model of an hour of :class:`~gym4real.microgrid.env.MicrogridEnv`:
the twin's terminal-voltage equation, the market's ask and bid, a linear price on the Bolun damage). It is
exact for that model on the grid: every feasible transition of every hour is scored.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def transition(
    ds: float, margin: float, ask: float, bid: float, hours: float, charge: float, ocv: float, slope: float
) -> tuple[float, float, float]:
    """Power (W), current (A) and trading (EUR) of an hour that moves the SoC by ``ds``.

    The current is ``ds * charge`` (coulomb counting, ``charge`` in A per unit of SoC), the terminal power
    ``(ocv + slope * I) * I`` (the twin's ``V(I) I = P``); the rest of the net power ``margin`` is traded.
    """
    current = ds * charge
    power = (ocv + slope * current) * current
    traded = margin - power
    trading = hours * traded * (ask if traded < 0.0 else bid)
    return power, current, trading


@njit(cache=True)
def circuit(table: np.ndarray, index: int, weight: float, i: int, dt: float) -> tuple[float, float]:
    """The terminal voltage ``ocv + slope * I`` at rest at grid SoC ``i`` (the twin's ``V(I) = a + b I``).

    ``table[p, k, i]`` holds R0, R1, C and OCV (``p``) at the lookup table's ``k``-th temperature and the
    grid's ``i``-th SoC; the hour's temperature lies ``weight`` of the way from table temperature ``index``
    to the next.
    """
    r0 = table[0, index, i] + weight * (table[0, index + 1, i] - table[0, index, i])
    r1 = table[1, index, i] + weight * (table[1, index + 1, i] - table[1, index, i])
    c = table[2, index, i] + weight * (table[2, index + 1, i] - table[2, index, i])
    ocv = table[3, index, i] + weight * (table[3, index + 1, i] - table[3, index, i])
    den = 1.0 / dt + 1.0 / (r1 * c)
    return ocv, r0 + 1.0 / c / den


@njit(cache=True)
def _feasible(power: float, current: float, margin: float, ocv: float, slope: float, limits: np.ndarray) -> bool:
    """Whether a = power / margin lies in [0, 1] and the pack's current and power bounds hold."""
    i_min, i_max, p_min, p_max = limits[0], limits[1], limits[2], limits[3]
    if margin > 0.0:
        return power <= margin and current <= i_max and power <= p_max
    return power >= margin and current >= i_min and current >= -ocv / (2.0 * slope) and power >= p_min


@njit(cache=True)
def solve(
    socs: np.ndarray,
    start: int,
    margin: np.ndarray,
    ask: np.ndarray,
    bid: np.ndarray,
    dt: float,
    charge: np.ndarray,
    table: np.ndarray,
    temp_index: np.ndarray,
    temp_weight: np.ndarray,
    limits: np.ndarray,
    trade_weight: float,
    price: float,
    cal_rate: np.ndarray,
    cal_soc: np.ndarray,
    cyc_rate: np.ndarray,
    cyc_soc: np.ndarray,
) -> tuple[np.ndarray, float]:
    """Backward dynamic programme over the SoC grid ``socs`` from grid point ``start``.

    Hour ``t`` moves from ``socs[i]`` to ``socs[j]``: with surplus (``margin[t] > 0``) only upwards, with a
    deficit only downwards, never when the margin is zero (``a = power / margin`` in [0, 1]). Its reward is
    ``trade_weight * trading - price * damage`` with the damage
    ``cal_rate[t] * cal_soc[i, j] + cyc_rate[t] * |socs[j] - socs[i]| * cyc_soc[i, j]`` (calendar aging, and
    cyclic aging priced per unit of SoC moved). :func:`circuit` gives the terminal voltage at ``socs[i]``
    and hour ``t``'s temperature (``temp_index[t]``, ``temp_weight[t]``); ``dt`` is the hour in seconds;
    ``limits`` holds the pack's current and power bounds ``(i_min, i_max, p_min, p_max)``.

    Returns:
        The optimal path (grid indices, ``len(margin) + 1``) and its value.
    """
    n_steps, n = margin.size, socs.size
    hours = dt / 3600.0
    value = np.zeros(n)
    nxt = np.empty(n)
    choice = np.empty((n_steps, n), dtype=np.int32)
    for t in range(n_steps - 1, -1, -1):
        m = margin[t]
        for i in range(n):
            o, s = circuit(table, temp_index[t], temp_weight[t], i, dt)
            _, _, trading = transition(0.0, m, ask[t], bid[t], hours, charge[t], o, s)
            best = trade_weight * trading - price * cal_rate[t] * cal_soc[i, i] + value[i]
            arg = i
            if m != 0.0:
                step = 1 if m > 0.0 else -1
                j = i + step
                while 0 <= j < n:
                    ds = socs[j] - socs[i]
                    power, current, trading = transition(ds, m, ask[t], bid[t], hours, charge[t], o, s)
                    if not _feasible(power, current, m, o, s, limits):
                        break
                    damage = cal_rate[t] * cal_soc[i, j] + cyc_rate[t] * abs(ds) * cyc_soc[i, j]
                    q = trade_weight * trading - price * damage + value[j]
                    if q > best:
                        best, arg = q, j
                    j += step
            nxt[i] = best
            choice[t, i] = arg
        value, nxt = nxt, value
    path = np.empty(n_steps + 1, dtype=np.int64)
    path[0] = start
    for t in range(n_steps):
        path[t + 1] = choice[t, path[t]]
    return path, value[start]


@njit(cache=True)
def totals(
    path: np.ndarray,
    socs: np.ndarray,
    margin: np.ndarray,
    ask: np.ndarray,
    bid: np.ndarray,
    dt: float,
    charge: np.ndarray,
    table: np.ndarray,
    temp_index: np.ndarray,
    temp_weight: np.ndarray,
    cal_rate: np.ndarray,
    cal_soc: np.ndarray,
    cyc_rate: np.ndarray,
    cyc_soc: np.ndarray,
) -> tuple[float, float, float]:
    """The model's trading (EUR), calendar damage and cyclic damage along a path of grid indices."""
    trading_sum = cal = cyc = 0.0
    for t in range(margin.size):
        i, j = path[t], path[t + 1]
        ds = socs[j] - socs[i]
        o, s = circuit(table, temp_index[t], temp_weight[t], i, dt)
        _, _, trading = transition(ds, margin[t], ask[t], bid[t], dt / 3600.0, charge[t], o, s)
        trading_sum += trading
        cal += cal_rate[t] * cal_soc[i, j]
        cyc += cyc_rate[t] * math.fabs(ds) * cyc_soc[i, j]
    return trading_sum, cal, cyc
