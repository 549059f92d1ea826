"""The hindsight planner's dynamic programme over the battery's state of charge, and its local search (numba).

:func:`solve` maximises, over the paths of a SoC grid, the sum of each hour's transition reward
:func:`transition` (the planner's model of an hour of :class:`~gym4real.microgrid.env.MicrogridEnv`:
the twin's terminal-voltage equation, the market's ask and bid, a linear price on the Bolun damage). It is
exact for that model on the grid: every feasible transition of every hour is scored.

:func:`improve` then searches around the plan through the twin itself: the batched env's compiled hour
(:func:`gym4real.microgrid.vector_kernel.step_copies`, the single env's numbers bit for bit), each copy
tracking its own SoC targets as the planner does (:func:`track`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from gym4real.microgrid.vector_kernel import _bilinear, step_copies


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


@njit(cache=True)
def track(
    targets: np.ndarray,
    skip: np.ndarray,
    battery: np.ndarray,
    clock: np.ndarray,
    exogenous: tuple[np.ndarray, np.ndarray, np.ndarray],
    grid: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    constants: tuple[float, ...],
    actions: np.ndarray,
) -> None:
    """Each copy's action (float32, as the planner sends it) that moves its SoC to ``targets[copy]`` this hour.

    As :func:`gym4real.microgrid.hindsight._tracking`: the terminal power ``V(I) I`` of the current that
    reaches the target (``V(I) = a + b I`` at the copy's state), as a fraction of the hour's net power,
    clipped to [0, 1]; 0 when the net power is 0.
    """
    demand_table, hourly, _ = exogenous
    grid_temps, grid_socs, values = grid[0], grid[1], grid[2]
    dt, kelvin = constants[0], constants[13]
    for i in range(targets.size):
        if skip[i]:
            continue
        r = clock[0, i]
        margin = hourly[r % hourly.shape[0], 0] - demand_table[clock[3, i], r % demand_table.shape[1]]
        if margin == 0.0:
            actions[i] = 0.0
            continue
        soc, temp, v_rc = battery[0, i], battery[3, i], battery[4, i]
        r0, r1, c, ocv = _bilinear(grid_temps, grid_socs, values, temp - kelvin, soc)
        den = 1.0 / dt + 1.0 / (r1 * c)
        a = ocv - v_rc / dt / den
        b = r0 + 1.0 / c / den
        current = (targets[i] - soc) * battery[5, i] * 3600.0 / dt
        fraction = min(max((a + b * current) * current / margin, 0.0), 1.0)
        actions[i] = float(np.float32(fraction))


@njit(cache=True)
def _copy(source: int, target: int, state: tuple[np.ndarray, ...]) -> None:
    """Copy the twin of copy ``source`` into copy ``target`` (state rows, rainflow stack and counters, clock)."""
    battery, stack, size, walk, last, damage, clock = state
    battery[:, target] = battery[:, source]
    for k in range(size[source]):
        stack[target, k, :] = stack[source, k, :]
    size[target] = size[source]
    walk[:, target] = walk[:, source]
    last[:, target] = last[:, source]
    damage[:, target] = damage[:, source]
    clock[:, target] = clock[:, source]


@njit(cache=True)
def _hour(
    targets: np.ndarray,
    skip: np.ndarray,
    state: tuple[np.ndarray, ...],
    args: tuple,  # type: ignore[type-arg]
    weights: tuple[float, float],
    actions: np.ndarray,
    sums: np.ndarray,
    ended: np.ndarray,
    obs: np.ndarray,
    gained: np.ndarray,
    traded: np.ndarray,
) -> None:
    """Step every copy not skipped one hour towards its target; add its objective to ``gained[copy]``.

    Its trading term goes to ``traded[copy]`` too.
    """
    battery, stack, size, walk, last, damage, clock = state
    exogenous, grid, constants, aging, cyclic, flags = args
    sums[:] = 0.0
    ended[:] = False
    track(targets, skip, battery, clock, exogenous, grid, constants, actions)
    step_copies(
        actions, skip, battery, stack, size, walk, last, damage, clock,
        exogenous, grid, constants, aging, cyclic, flags, sums, ended, obs,
    )  # fmt: skip
    for i in range(actions.size):
        if not skip[i]:
            gained[i] += weights[0] * sums[0, i] + weights[1] * sums[1, i]
            traded[i] += weights[0] * sums[0, i]


@njit(cache=True)
def _degradation(state: tuple[np.ndarray, ...], i: int, aging: tuple[float, ...]) -> float:
    """The SoH lost to copy ``i``'s damage so far: the Bolun degradation of calendar plus cycle damage."""
    battery, damage = state[0], state[5]
    f_d = battery[6, i] + (damage[0, i] + damage[1, i] + damage[2, i])
    alpha, beta = aging[0], aging[1]
    return 1.0 - alpha * math.exp(-beta * f_d) - (1.0 - alpha) * math.exp(-f_d)


@njit(cache=True)
def _buffers(copies: int, obs_size: int) -> tuple[np.ndarray, ...]:
    """The per-copy work arrays of :func:`_hour`: actions, targets, sums, ended, observations, objectives."""
    return (
        np.zeros(copies),
        np.zeros(copies),
        np.zeros((10, copies)),
        np.zeros((2, copies), dtype=np.bool_),
        np.zeros((copies, obs_size), dtype=np.float32),
        np.zeros(copies),
        np.zeros(copies),
    )


@njit(cache=True)
def play(
    targets: np.ndarray,
    state: tuple[np.ndarray, ...],
    args: tuple,  # type: ignore[type-arg]
    weights: tuple[float, float],
    obs_size: int,
) -> float:
    """The objective of tracking ``targets`` from copy 0's state (the episode's start), played in copy 1."""
    copies = state[0].shape[1]
    actions, wanted, sums, ended, obs, gained, traded = _buffers(copies, obs_size)
    skip = np.ones(copies, dtype=np.bool_)
    skip[1] = False
    _copy(0, 1, state)
    for k in range(targets.size - 1):
        wanted[1] = targets[k + 1]
        _hour(wanted, skip, state, args, weights, actions, sums, ended, obs, gained, traded)
        if ended[0, 1] or ended[1, 1]:
            break
    return gained[1]


@njit(cache=True)
def improve(
    targets: np.ndarray,
    low: float,
    high: float,
    changes: np.ndarray,
    spans: np.ndarray,
    window: int,
    tolerance: float,
    state: tuple[np.ndarray, ...],
    args: tuple,  # type: ignore[type-arg]
    weights: tuple[float, float],
    obs_size: int,
) -> tuple[float, int]:
    """Local search over the SoC targets ``targets`` (updated in place) through the compiled twin.

    ``state`` holds ``3 + 2 * len(changes) * len(spans)`` copies of the twin, copy 0 at the episode's start
    (only it is read). A pass plays the year hour by hour in copy 1, tracking the targets. Before each hour
    whose target or next target moves, copies 2 and up start from copy 1's state and play ``window`` hours:
    copy 2 the targets, each other copy the targets with the next ``span`` of them moved by ``+-change``
    (a span of 0: the run of targets equal to this hour's), within ``[low, high]``. Each copy's window is
    scored by its trading plus the degradation of the damage it has reached (calendar and cycles, the open
    ones included); the best copy's targets are kept. After the first pass, a pass tries only the hours within
    ``window`` of a target the previous pass changed. A pass's objective is the year copy 1 played,
    exactly; the targets of the best pass (the plan's own included) are kept. Passes repeat until one gains
    at most ``tolerance`` of the objective's magnitude. The objective of an hour is
    ``weights[0] * trading + weights[1] * degradation``.

    Returns:
        The objective of the kept targets as the twin plays them, and the number of passes.
    """
    hours = targets.size - 1
    moves = 2 * changes.size * spans.size
    copies = 3 + moves
    offset, span = np.zeros(copies), np.zeros(copies, dtype=np.int64)
    aging, per_soh = args[3], args[2][12]
    actions, wanted, sums, ended, obs, gained, traded = _buffers(copies, obs_size)
    main, scratch = np.ones(copies, dtype=np.bool_), np.ones(copies, dtype=np.bool_)
    main[1] = False
    best_value = previous = play(targets, state, args, weights, obs_size)
    best = targets.copy()
    passes = 0
    near = np.ones(hours + 1, dtype=np.bool_)  # the hours tried in this pass: all, then those near a change
    while True:
        passes += 1
        changed = np.zeros(hours + 1, dtype=np.int64)
        _copy(0, 1, state)
        gained[1] = 0.0
        for k in range(hours):
            moving = targets[k + 1] != targets[k] or (k + 2 <= hours and targets[k + 2] != targets[k + 1])
            if near[k] and moving:
                run = 1
                while k + run + 1 <= hours and targets[k + run + 1] == targets[k + 1]:
                    run += 1
                scratch[:] = True
                for j in range(2, copies):
                    _copy(1, j, state)
                    gained[j] = traded[j] = 0.0
                    m = j - 3
                    offset[j] = 0.0 if m < 0 else (1.0 - 2.0 * (m % 2)) * changes[(m // 2) % changes.size]
                    span[j] = 0 if m < 0 else spans[m // (2 * changes.size)]
                    if span[j] == 0 and m >= 0:
                        span[j] = run
                    scratch[j] = False
                    for h in range(min(span[j], hours - k)):
                        if not low <= targets[k + h + 1] + offset[j] <= high:
                            scratch[j] = True
                for h in range(min(window, hours - k)):
                    for j in range(2, copies):
                        wanted[j] = targets[k + h + 1] + (offset[j] if h < span[j] else 0.0)
                    _hour(wanted, scratch, state, args, weights, actions, sums, ended, obs, gained, traded)
                    if ended.any():
                        break
                for j in range(2, copies):  # the damage the window leaves, as degradation
                    gained[j] = traded[j] - weights[1] * per_soh * _degradation(state, j, aging)
                winner = 2
                for j in range(3, copies):
                    if not scratch[j] and gained[j] > gained[winner]:
                        winner = j
                for h in range(min(span[winner], hours - k)):
                    targets[k + h + 1] += offset[winner]
                    changed[k + h + 1] = 1
            wanted[1] = targets[k + 1]
            _hour(wanted, main, state, args, weights, actions, sums, ended, obs, gained, traded)
            if ended[0, 1] or ended[1, 1]:
                break
        value = gained[1]
        if value > best_value:
            best_value = value
            best[:] = targets
        if value - previous <= tolerance * abs(value):
            targets[:] = best
            return best_value, passes
        previous = value
        # the next pass tries the hours within a window of a changed target (their windows saw other targets)
        total = np.cumsum(changed)
        for k in range(hours + 1):
            near[k] = total[min(hours, k + window)] - (total[k - window - 1] if k > window else 0) > 0
