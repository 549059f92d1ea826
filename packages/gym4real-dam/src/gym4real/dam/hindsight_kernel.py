"""The hindsight planner's dynamic programme over the lake level, compiled (numba).

Each candidate day is integrated with the batched env's own compiled release bounds
(:func:`gym4real.dam.vector_kernel._release` and ``_constant``, the single env's sub-step expressions), so
the planner's transitions are the environment's hourly mass balance and release bounds.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gym4real.dam.vector_kernel import _release


@njit(cache=True)
def _q_max(h: float, lake: tuple[float, ...]) -> float:
    """``q_max(h)`` above l_min, as :func:`_release` evaluates it (linear up to l_lim, then the rating curve)."""
    llim, k, c, alpha, beta, cr = lake[3], lake[4], lake[5], lake[6], lake[7], lake[8]
    return h * k + c if h <= llim else ((h - alpha) ** beta) * cr


@njit(cache=True)
def _regime(h: float, q_max: float, wanted: float, lake: tuple[float, ...]) -> int:
    """:func:`~gym4real.dam.vector_kernel._constant` given ``q_max(h)``: 0, 1, 2 (a constant release) or -1."""
    lmin, lmax, llim = lake[1], lake[2], lake[3]
    if h <= lmin:
        return 0
    if h > lmax or q_max < wanted:
        return -1
    return 1 if h <= llim else 2


@njit(cache=True)
def _days(
    storage: float,
    decisions: np.ndarray,
    inflow: float,
    evaporation: float,
    lake: tuple[float, float, float, float, float, float, float, float, float, float],
    evaporates: bool,
    substeps: int,
    after: np.ndarray,
    mean_release: np.ndarray,
) -> int:
    """Integrate one day from ``storage`` for each wanted release: the storages after it and the mean releases.

    Returns the number of candidates that give distinct days: the ``decisions`` are ascending, and once the
    wanted release sets no sub-step's release (the bounds decide it all day: forced above l_max, nothing
    up to l_min, ``q_max`` below the wanted release), every larger wanted release gives that same day, so
    they are left out.

    As :func:`~gym4real.dam.vector_kernel.integrate_copies` does: a day whose first and last sub-steps
    release the same constant (:func:`_constant`'s test) releases it in every sub-step, and the storage
    moves by ``substeps`` equal steps (summed here in one product: a rounding difference, not another day);
    any other day runs sub-step by sub-step with the env's release bounds (:func:`_release`). ``q_max`` at
    the start is evaluated once; at the end only where the level fell or changed branch (it is monotone in
    the level within a branch, so a rise keeps a feasible release feasible).
    """
    area, lmin, lmax, llim, dt = lake[0], lake[1], lake[2], lake[3], lake[9]
    h0 = storage / area + lmin
    q0 = _q_max(h0, lake) if h0 > lmin else 0.0
    for j in range(decisions.size):
        m = decisions[j]
        first = _regime(h0, q0, m, lake)
        if first >= 0:
            r = m if first > 0 else 0.0
            net = inflow - r
            if evaporates:
                net -= evaporation
            h1 = (storage + net * dt * (substeps - 1)) / area + lmin
            if first == 0:
                same = h1 <= lmin
            elif h1 >= h0 and (h1 <= llim) == (h0 <= llim):
                same = _regime(h1, q0, m, lake) == first  # q_max(h1) >= q0 >= m
            else:
                same = h1 > lmin and _regime(h1, _q_max(h1, lake), m, lake) == first
            if same:
                after[j] = storage + net * dt * substeps
                mean_release[j] = r
                continue
        s, total, bound = storage, 0.0, True
        for _ in range(substeps):
            h = s / area + lmin
            r = _release(h, m, lake)
            bound = bound and (h > lmax or h <= lmin or r < m)  # a release the wanted one does not set
            total += r
            net = inflow - r
            if evaporates:
                net -= evaporation
            s += net * dt
        after[j] = s
        mean_release[j] = total / substeps
        if bound:
            return j + 1
    return decisions.size


@njit(cache=True)
def _value(values: np.ndarray, low: float, step: float, level: float) -> float:
    """The value function on the uniform level grid, interpolated linearly (clamped at the ends)."""
    x = (level - low) / step
    last = values.size - 1
    if x <= 0.0:
        return values[0]
    if x >= last:
        return values[last]
    i = int(x)
    f = x - i
    return values[i] + f * (values[i + 1] - values[i])


@njit(cache=True)
def _reward(
    release: float,
    level: float,
    demand: float,
    min_flow: float,
    weight: float,
    costs: tuple[float, float, float, float, float],
) -> float:
    """The day's objective (deficit + overflow + starving, weighted), as :meth:`DamEnv.step` computes it."""
    w_deficit, w_overflow, w_starving, flood, starving = costs
    supplied = release - min_flow
    if supplied < 0.0:
        supplied = 0.0
    shortfall = demand - supplied
    deficit = (shortfall if shortfall > 0.0 else 0.0) * weight
    reward = -deficit * w_deficit
    if level > flood:
        reward -= w_overflow
    if level < starving:
        reward -= w_starving
    return reward


@njit(cache=True)
def backward(
    low: float,
    step: float,
    points: int,
    decisions: np.ndarray,
    counts: np.ndarray,
    exogenous: np.ndarray,
    lake: tuple[float, float, float, float, float, float, float, float, float, float],
    evaporates: bool,
    substeps: int,
    costs: tuple[float, float, float, float, float],
    terminal: np.ndarray | None = None,
) -> np.ndarray:
    """The optimal value ``V[t, g]`` of the rest of the episode from grid level ``g`` at the start of day ``t``.

    Args:
        low: The grid's lowest level (m).
        step: The grid's spacing (m).
        points: The number of grid levels.
        decisions: ``(days, K)``: each day's candidate wanted releases (m3/s), the first ``counts[t]`` used.
        counts: The number of candidates of each day.
        exogenous: ``(days, 5)``: demand, inflow, minimum flow, evaporation and deficit weight of each day.
        lake: The compiled day's constants (surface, l_min, ..., dt; see ``DamVectorEnv``).
        evaporates: Whether evaporation is subtracted.
        substeps: Sub-steps per day.
        costs: Weights of deficit, overflow and starving; flood and starving levels.
        terminal: ``(points,)``: the value of each grid level after the last day; None: 0 (nothing is
            scored after the episode).

    Returns:
        ``(days + 1, points)``; the last row is ``terminal``.
    """
    days = exogenous.shape[0]
    area, lmin = lake[0], lake[1]
    values = np.zeros((days + 1, points))
    if terminal is not None:
        values[days] = terminal
    width = decisions.shape[1]
    after = np.empty(width)
    mean_release = np.empty(width)
    for t in range(days - 1, -1, -1):
        demand, inflow, min_flow, evaporation, weight = exogenous[t]
        k = counts[t]
        for g in range(points):
            storage = area * (low + g * step - lmin)
            distinct = _days(
                storage, decisions[t, :k], inflow, evaporation, lake, evaporates, substeps, after, mean_release
            )
            best = -np.inf
            for j in range(distinct):
                level = after[j] / area + lmin
                value = _reward(mean_release[j], level, demand, min_flow, weight, costs)
                value += _value(values[t + 1], low, step, level)
                if value > best:
                    best = value
            values[t, g] = best
    return values


@njit(cache=True)
def choose(
    storage: float,
    t: int,
    values: np.ndarray,
    low: float,
    step: float,
    decisions: np.ndarray,
    exogenous: np.ndarray,
    lake: tuple[float, float, float, float, float, float, float, float, float, float],
    evaporates: bool,
    substeps: int,
    costs: tuple[float, float, float, float, float],
) -> int:
    """The index of the best candidate of day ``t`` from the exact ``storage`` (ties: the first)."""
    demand, inflow, min_flow, evaporation, weight = exogenous[t]
    k = decisions.size
    after = np.empty(k)
    mean_release = np.empty(k)
    distinct = _days(storage, decisions, inflow, evaporation, lake, evaporates, substeps, after, mean_release)
    area, lmin = lake[0], lake[1]
    best, index = -np.inf, 0
    for j in range(distinct):
        level = after[j] / area + lmin
        value = _reward(mean_release[j], level, demand, min_flow, weight, costs)
        value += _value(values[t + 1], low, step, level)
        if value > best:
            best, index = value, j
    return index


@njit(cache=True)
def rollout(
    storage: float,
    plan: np.ndarray,
    start: int,
    exogenous: np.ndarray,
    lake: tuple[float, float, float, float, float, float, float, float, float, float],
    evaporates: bool,
    substeps: int,
    costs: tuple[float, float, float, float, float],
    storages: np.ndarray,
    rewards: np.ndarray,
) -> float:
    """Play the wanted releases ``plan`` from day ``start`` and ``storage`` to the end of the episode.

    Each day is integrated by :func:`_days` (the env's compiled hourly mass balance) and scored by
    :func:`_reward`; the storage after day ``t`` goes to ``storages[t + 1]``, the day's objective to
    ``rewards[t]``.

    Returns:
        The objective of days ``start`` to the end.
    """
    area, lmin = lake[0], lake[1]
    wanted, after, mean_release = np.empty(1), np.empty(1), np.empty(1)
    total, s = 0.0, storage
    for t in range(start, exogenous.shape[0]):
        demand, inflow, min_flow, evaporation, weight = exogenous[t]
        wanted[0] = plan[t] if plan[t] > min_flow else min_flow
        _days(s, wanted, inflow, evaporation, lake, evaporates, substeps, after, mean_release)
        s = after[0]
        storages[t + 1] = s
        rewards[t] = _reward(mean_release[0], s / area + lmin, demand, min_flow, weight, costs)
        total += rewards[t]
    return total


@njit(cache=True)
def improve(
    plan: np.ndarray,
    storage: float,
    exogenous: np.ndarray,
    lake: tuple[float, float, float, float, float, float, float, float, float, float],
    evaporates: bool,
    substeps: int,
    costs: tuple[float, float, float, float, float],
    low: np.ndarray,
    high: np.ndarray,
    deltas: np.ndarray,
    window: int,
    tolerance: float,
) -> tuple[float, int]:
    """Local search over the daily releases ``plan`` (updated in place), each candidate played day by day.

    A pass tries, for each change ``d`` of ``deltas`` (m3/s) and each day ``t``: its release ``+-d`` (the
    water held or released moves every later level), and moving ``d`` of release between day ``t`` and each
    day ``s`` up to ``window`` days later (the levels between them move, those after ``s`` return); releases
    stay within ``[low, high]``. A candidate is played from day ``t`` (:func:`_days`, :func:`_reward`); once
    its storage after ``s`` is back on the plan's path (to 1e-12 of the storage) the plan's later days
    complete the estimate, and a candidate estimated better is played to the end of the year. It is kept
    when that objective is higher. Passes repeat until one gains at most ``tolerance`` of the objective's
    magnitude.

    Returns:
        The objective of the improved plan (as :func:`rollout` plays it) and the number of passes.
    """
    days = exogenous.shape[0]
    storages, rewards = np.empty(days + 1), np.empty(days)
    trial_storages, trial_rewards = np.empty(days + 1), np.empty(days)
    storages[0] = storage
    current = rollout(storage, plan, 0, exogenous, lake, evaporates, substeps, costs, storages, rewards)
    trial = plan.copy()
    area, lmin = lake[0], lake[1]
    wanted, after, mean_release = np.empty(1), np.empty(1), np.empty(1)
    passes = 0
    while True:
        passes += 1
        before = current
        for d in deltas:
            for t in range(days):
                prefix = 0.0
                for k in range(t):
                    prefix += rewards[k]
                for s in range(t, min(days, t + window + 1)):
                    for sign in (1.0, -1.0):
                        first, second = plan[t] + sign * d, plan[s] - sign * d
                        if first < low[t] or first > high[t] or (s > t and (second < low[s] or second > high[s])):
                            continue
                        trial[t] = first
                        if s > t:
                            trial[s] = second
                        value, level, joined = prefix, storages[t], -1
                        for k in range(t, days):
                            demand, inflow, min_flow, evaporation, weight = exogenous[k]
                            wanted[0] = trial[k] if trial[k] > min_flow else min_flow
                            _days(level, wanted, inflow, evaporation, lake, evaporates, substeps, after, mean_release)
                            level = after[0]
                            reward = _reward(mean_release[0], level / area + lmin, demand, min_flow, weight, costs)
                            trial_storages[k + 1], trial_rewards[k] = level, reward
                            value += reward
                            if k >= s and abs(level - storages[k + 1]) <= 1e-12 * abs(storages[k + 1]):
                                joined = k + 1
                                break
                        if joined >= 0:
                            for k in range(joined, days):
                                value += rewards[k]
                            if value > current:  # an estimate: play the candidate to the end of the year
                                value = prefix + rollout(
                                    storages[t], trial, t, exogenous, lake, evaporates, substeps, costs,
                                    trial_storages, trial_rewards,
                                )  # fmt: skip
                        if value > current:
                            plan[t], plan[s] = trial[t], trial[s]
                            current = value
                            storages[t + 1 :] = trial_storages[t + 1 :]
                            rewards[t:] = trial_rewards[t:]
                        else:
                            trial[t], trial[s] = plan[t], plan[s]
        if current - before <= tolerance * abs(current):
            return current, passes
