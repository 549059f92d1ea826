"""The batched microgrid's decision as one compiled loop over the copies and their hours (numba).

:class:`~gym4real.microgrid.vector.MicrogridVectorEnv` runs :func:`step_copies` when numba is installed
(the extra ``fast``) and numpy otherwise. Each copy's hours evaluate the scalar code's expressions in its
order (:meth:`~gym4real.microgrid.battery.BatteryTwin.step` with every correction on, the Bolun aging, the
streaming rainflow counter, :meth:`~gym4real.microgrid.env.MicrogridEnv.step`'s sums) with the C library's
``exp`` and ``pow``, as Python's ``math`` has them: the numbers of the single env, bit for bit. A copy
that ends inside a decision stops there, as the single env does. The helpers are inlined in numba's IR
(``inline="always"``): as calls they took about a fifth of the time.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from gym4real.microgrid.aging import CYCLIC_FACTORS

# the cyclic stress factors by code, their index in CYCLIC_FACTORS (``cyclic`` keeps AgingParams.cyclic's order)
SOC, TEMPERATURE, DOD_BOLUN = (CYCLIC_FACTORS.index(f) for f in ("soc", "temperature", "dod_bolun"))


@njit(cache=True, inline="always")
def _bilinear(
    grid_temps: np.ndarray, grid_socs: np.ndarray, values: np.ndarray, temp_c: float, soc: float
) -> tuple[float, float, float, float]:
    """R0, R1, C and OCV at ``(temp_c, soc)`` (:meth:`ParameterGrid.bilinear`, clamped at the edges)."""
    ts, ss = grid_temps, grid_socs
    if temp_c <= ts[0]:
        i, wt = 0, 0.0
    elif temp_c >= ts[-1]:
        i, wt = ts.size - 2, 1.0
    else:
        i = int(np.searchsorted(ts, temp_c, side="right")) - 1
        wt = (temp_c - ts[i]) / (ts[i + 1] - ts[i])
    if soc <= ss[0]:
        j, ws = 0, 0.0
    elif soc >= ss[-1]:
        j, ws = ss.size - 2, 1.0
    else:
        j = int(np.searchsorted(ss, soc, side="right")) - 1
        ws = (soc - ss[j]) / (ss[j + 1] - ss[j])
    w11 = wt * ws
    w10 = wt - w11
    w01 = ws - w11
    w00 = 1.0 - wt - w01
    v = values
    return (
        w00 * v[0, i, j] + w01 * v[0, i, j + 1] + w10 * v[0, i + 1, j] + w11 * v[0, i + 1, j + 1],
        w00 * v[1, i, j] + w01 * v[1, i, j + 1] + w10 * v[1, i + 1, j] + w11 * v[1, i + 1, j + 1],
        w00 * v[2, i, j] + w01 * v[2, i, j + 1] + w10 * v[2, i + 1, j] + w11 * v[2, i + 1, j + 1],
        w00 * v[3, i, j] + w01 * v[3, i, j + 1] + w10 * v[3, i + 1, j] + w11 * v[3, i + 1, j + 1],
    )


@njit(cache=True, inline="always")
def _dvdt(xs: np.ndarray, ys: np.ndarray, soc: float) -> float:
    """dOCV/dT at ``soc`` (:meth:`BatteryParams.dvdt`)."""
    j = np.searchsorted(xs[1 : xs.size - 1], soc, side="left")  # the first segment whose end is >= soc
    return ys[j] + (ys[j + 1] - ys[j]) * (soc - xs[j]) / (xs[j + 1] - xs[j])


@njit(cache=True, inline="always")
def _temperature_stress(aging: tuple[float, ...], temp: float) -> float:
    """:meth:`AgingParams.temperature_stress`."""
    k_temp, temp_ref = aging[5], aging[6]
    return math.exp(k_temp * (temp - temp_ref) * (temp_ref / temp))


@njit(cache=True, inline="always")
def _half_damage(
    aging: tuple[float, ...], cyclic: np.ndarray, x0: float, x1: float, span: float, sum_temp: float
) -> float:
    """Damage of the half cycle from ``x0`` to ``x1`` over ``span`` points (:meth:`AgingParams.cycle_damage`)."""
    dod, mean_soc, mean_temp = abs(x1 - x0), 0.5 * (x0 + x1), sum_temp / span
    value = 0.5
    for factor in cyclic:
        if factor == DOD_BOLUN:
            value *= 0.0 if dod <= 0.0 else 1.0 / (aging[7] * dod ** aging[8] + aging[9])
        elif factor == SOC:
            value *= math.exp(aging[3] * (mean_soc - aging[4]))
        else:
            value *= _temperature_stress(aging, mean_temp)
    return value


@njit(cache=True, inline="always")
def _push_reversal(
    i: int, stack: np.ndarray, size: np.ndarray, last: np.ndarray, damage: np.ndarray, aging: tuple[float, ...],
    cyclic: np.ndarray,
) -> None:  # fmt: skip
    """Push copy ``i``'s latest point as a reversal and extract the cycles it closes (``StreamingRainflow``).

    ``damage`` rows: closed cycles, the residue's half cycles, the open tail.
    """
    k = size[i]
    half = 0.0
    if k > 0:
        b = k - 1
        half = _half_damage(
            aging, cyclic, stack[i, b, 0], last[0, i], last[1, i] - stack[i, b, 1], last[2, i] - stack[i, b, 2]
        )
        damage[1, i] += half
    stack[i, k, 0], stack[i, k, 1], stack[i, k, 2], stack[i, k, 3] = last[0, i], last[1, i], last[2, i], half
    k += 1
    while k >= 3:
        c, b, a = stack[i, k - 1, 0], stack[i, k - 2, 0], stack[i, k - 3, 0]
        if abs(c - b) < abs(b - a):
            break
        if k == 3:  # the cycle holds the starting point: a half cycle, the first point dropped
            bh = stack[i, 1, 3]
            damage[0, i] += bh
            damage[1, i] -= bh
            for r in range(4):
                stack[i, 0, r] = stack[i, 1, r]
                stack[i, 1, r] = stack[i, 2, r]
            stack[i, 0, 3] = 0.0
            k = 2
        else:  # a full cycle: its two points dropped
            ah, bh, ch = stack[i, k - 3, 3], stack[i, k - 2, 3], stack[i, k - 1, 3]
            damage[0, i] += 2.0 * bh
            damage[1, i] -= bh + ch + ah
            z = k - 4
            for r in range(3):
                stack[i, k - 3, r] = stack[i, k - 1, r]
            y = k - 3
            hc = _half_damage(
                aging,
                cyclic,
                stack[i, z, 0],
                stack[i, y, 0],
                stack[i, y, 1] - stack[i, z, 1],
                stack[i, y, 2] - stack[i, z, 2],
            )
            stack[i, y, 3] = hc
            damage[1, i] += hc
            k -= 2
    size[i] = k
    damage[2, i] = 0.0


@njit(cache=True, inline="always")
def _push(
    i: int,
    x: float,
    temp: float,
    stack: np.ndarray,
    size: np.ndarray,
    walk: np.ndarray,
    last: np.ndarray,
    damage: np.ndarray,
    aging: tuple[float, ...],
    cyclic: np.ndarray,
) -> None:
    """Add the next point ``(x, temp)`` of copy ``i``'s series (``StreamingRainflow.push`` after the first).

    ``walk`` rows: points so far, cumulative temperature, direction of the latest move.
    """
    index, cum = walk[0, i], walk[1, i]
    walk[0, i] = index + 1.0
    walk[1, i] = cum + temp
    d = x - last[0, i]
    if d == 0.0:  # flat: not a peak or valley, only the temperature sums move on
        return
    if size[i] == 0 or d * walk[2, i] < 0.0:
        _push_reversal(i, stack, size, last, damage, aging, cyclic)
    walk[2, i] = d
    last[0, i], last[1, i], last[2, i] = x, index, cum
    top = size[i] - 1
    damage[2, i] = _half_damage(aging, cyclic, stack[i, top, 0], x, index - stack[i, top, 1], cum - stack[i, top, 2])


@njit(cache=True)
def step_copies(
    actions: np.ndarray,
    skip: np.ndarray,
    battery: np.ndarray,
    stack: np.ndarray,
    size: np.ndarray,
    walk: np.ndarray,
    last: np.ndarray,
    damage: np.ndarray,
    clock: np.ndarray,
    exogenous: tuple[np.ndarray, np.ndarray, np.ndarray],
    grid: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    constants: tuple[float, ...],
    aging: tuple[float, ...],
    cyclic: np.ndarray,
    flags: tuple[int, int, int, int, int],
    sums: np.ndarray,
    ended: np.ndarray,
    obs: np.ndarray,
) -> None:
    """One decision of every copy, in place: its hours until the decision ends or the copy does.

    Args:
        actions: The fraction of the net power routed to the battery, per copy.
        skip: The copies left as they are (sums 0, not ended).
        battery: The twin's state, rows :data:`~gym4real.microgrid.vector.STATE`; updated.
        stack: The rainflow residue stacks ``(copies, depth, 4)`` (x, index, cumulative temperature, half
            damage), deep enough for one more reversal per hour; updated.
        size: Points in each stack, updated.
        walk: Rainflow rows points so far, cumulative temperature, latest direction; updated.
        last: The latest point's x, index and cumulative temperature; updated.
        damage: Rainflow rows closed, residue and tail damage; updated.
        clock: Rows data row, hours since the reset, the episode's limit of hours, profile column (int64);
            updated.
        exogenous: Demand ``(profiles, rows)``; PV, ask, bid and ambient temperature per data row
            ``(rows, 4)``; the observation's PV, ask, bid and time angles per data row
            (:meth:`~gym4real.microgrid.vector.MicrogridVectorEnv._exogenous_table`).
        grid: The lookup grid's temperatures (°C), SoCs, values ``(parameter, temperature, soc)``, and the
            dV/dT curve's SoCs and values.
        constants: dt, soc_min, soc_max, current_min, current_max, power_min, power_max, c_thermal,
            r_cond + r_conv, nominal capacity, end-of-life SoH, hours per step, EUR per unit of SoH,
            kelvin.
        aging: alpha_sei, beta_sei, k_t, k_soc, soc_ref, k_temp, temp_ref, k_delta1, k_delta2, k_delta3.
        cyclic: The cyclic stress factors' codes, in order.
        flags: Hours per decision, calendar time, calendar SoC and calendar temperature factors, SoH
            observed (0/1).
        sums: Out, rows :data:`~gym4real.microgrid.vector.SUMS` (zeros on entry): the single env's running
            sums of the decision.
        ended: Out, ``(2, copies)`` (False on entry): terminated (end of life), truncated (the episode's
            hours, not at the end of life).
        obs: Out, the observation of every copy stepped (as :meth:`MicrogridVectorEnv._obs`, float32).
    """
    demand_table, hourly, observed = exogenous
    grid_temps, grid_socs, values, dvdt_x, dvdt_y = grid
    dt, soc_min, soc_max, current_min, current_max, power_min, power_max = constants[:7]
    c_thermal, r_tot, nominal, eol_soh, hours, deg_per_soh, kelvin = constants[7:14]
    alpha, beta, k_t, k_soc, soc_ref = aging[0], aging[1], aging[2], aging[3], aging[4]
    interval, timed, calendar_soc, calendar_temp, observe_soh = flags
    n_rows, n_demand = hourly.shape[0], demand_table.shape[1]
    cth = c_thermal / dt
    for i in range(actions.size):
        if skip[i]:
            continue
        action = actions[i]
        trading = degradation = clipping = cost = 0.0
        e_demand = e_pv = e_in = e_out = e_sold = e_bought = 0.0
        terminated = truncated = False
        for _ in range(interval):
            r = clock[0, i]
            now = r % n_rows
            demand = demand_table[clock[3, i], r % n_demand]
            gen, t_amb = hourly[now, 0], hourly[now, 3]
            margin = gen - demand
            power = margin * action
            # BatteryTwin.step: 1. parameters at the state at the start of the step
            soc0, temp0, soh0, v_rc0 = battery[0, i], battery[3, i], battery[1, i], battery[4, i]
            charge = battery[5, i] * 3600.0 / dt
            r0, r1, c, ocv = _bilinear(grid_temps, grid_socs, values, temp0 - kelvin, soc0)
            den = 1.0 / dt + 1.0 / (r1 * c)
            a = ocv - v_rc0 / dt / den
            b = r0 + 1.0 / c / den
            # 2. feasible range
            lo_i = max((soc_min - soc0) * charge, current_min)
            hi_i = min((soc_max - soc0) * charge, current_max)
            lo_i, hi_i = min(lo_i, 0.0), max(hi_i, 0.0)
            lo_i = max(lo_i, -a / (2.0 * b))
            lo = max((a + b * lo_i) * lo_i, power_min)
            hi = min((a + b * hi_i) * hi_i, power_max)
            applied = lo if power < lo else hi if power > hi else power
            violation = 0.0
            if applied != power:
                disc = a * a + 4.0 * b * power
                i_req = 2.0 * power / (a + math.sqrt(disc)) if disc > 0.0 else -a / (2.0 * b)
                soc_req = soc0 + i_req / charge
                violation = max(max(soc_req - soc_max, soc_min - soc_req), 0.0)
            # 3. electrical
            current = 0.0
            if applied != 0.0:
                current = 2.0 * applied / (a + math.sqrt(max(a * a + 4.0 * b * applied, 0.0)))
            v_rc = (v_rc0 / dt - current / c) / den
            i_r1 = v_rc / r1
            # 4. state of charge
            soc = soc0 + current / charge
            soc = 0.0 if soc < 0.0 else 1.0 if soc > 1.0 else soc
            # 5. thermal
            heat = r0 * current * current + r1 * i_r1 * i_r1
            dvdt = _dvdt(dvdt_x, dvdt_y, soc)
            core = (cth * temp0 + t_amb / r_tot + heat) / (cth + 1.0 / r_tot - dvdt * current)
            # 6. aging (BolunAging.step): calendar, streaming rainflow, monotone degradation
            if timed:
                stress = 1.0
                if calendar_soc:
                    stress *= math.exp(k_soc * (0.5 * (soc0 + soc) - soc_ref))
                if calendar_temp:
                    stress *= _temperature_stress(aging, 0.5 * (temp0 + core))
                battery[6, i] += k_t * dt * stress
            _push(i, soc, core, stack, size, walk, last, damage, aging, cyclic)
            f_d = battery[6, i] + (damage[0, i] + damage[1, i] + damage[2, i])
            if f_d > battery[7, i]:
                battery[7, i] = f_d
                battery[8, i] = 1.0 - alpha * math.exp(-beta * f_d) - (1.0 - alpha) * math.exp(-f_d)
            soh = battery[2, i] - battery[8, i]
            battery[0, i], battery[1, i], battery[3, i], battery[4, i] = soc, soh, core, v_rc
            battery[5, i] = nominal * soh
            # MicrogridEnv.step's sums
            traded = margin - applied
            if traded < 0.0:
                trading += traded * hourly[now, 1] * hours
                e_bought -= traded * hours
            else:
                trading += traded * hourly[now, 2] * hours
                e_sold += traded * hours
            degradation -= (soh0 - soh) * deg_per_soh
            clipping -= abs(power - applied) * hours
            cost += violation
            e_demand += demand * hours
            e_pv += gen * hours
            if applied > 0.0:
                e_in += applied * hours
            else:
                e_out -= applied * hours
            clock[0, i] = r + 1
            clock[1, i] += 1
            terminated = soh <= eol_soh
            truncated = clock[1, i] >= clock[2, i]
            if terminated or truncated:
                break
        sums[0, i], sums[1, i], sums[2, i], sums[3, i] = trading, degradation, clipping, cost
        sums[4, i], sums[5, i], sums[6, i], sums[7, i], sums[8, i], sums[9, i] = (
            e_demand, e_pv, e_in, e_out, e_sold, e_bought,
        )  # fmt: skip
        ended[0, i] = terminated
        ended[1, i] = truncated and not terminated
        row = clock[0, i]
        temp, e = battery[3, i], min(row, observed.shape[0] - 1)
        obs[i, 0] = 250.0 if temp < 250.0 else 400.0 if temp > 400.0 else temp
        obs[i, 1] = battery[0, i]
        obs[i, 2] = demand_table[clock[3, i], (row - 1) % n_demand]
        k = 3
        if observe_soh:
            soh = battery[1, i]
            obs[i, 3] = 0.0 if soh < 0.0 else 1.0 if soh > 1.0 else soh
            k = 4
        for c in range(7):
            obs[i, k + c] = observed[e, c]
