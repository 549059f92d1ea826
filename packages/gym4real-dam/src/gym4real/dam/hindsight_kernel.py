"""The hindsight planner's dynamic programme over the lake level, compiled (numba).

Each candidate day is integrated by the batched env's own compiled day,
:func:`gym4real.dam.vector_kernel.integrate_copies` (the single env's sub-step expressions, bit for bit), so
the planner's transitions are the environment's hourly mass balance and release bounds.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gym4real.dam.vector_kernel import integrate_copies


@njit(cache=True)
def _days(
    storage: float,
    decisions: np.ndarray,
    inflow: float,
    evaporation: float,
    lake: tuple[float, float, float, float, float, float, float, float, float, float],
    evaporates: bool,
    releases: np.ndarray,
    after: np.ndarray,
    mean_release: np.ndarray,
) -> None:
    """Integrate one day from ``storage`` for each wanted release: the storages after it and the mean releases."""
    k = decisions.size
    after[:k] = storage
    integrate_copies(
        after[:k],
        decisions,
        np.full(k, inflow),
        np.full(k, evaporation),
        lake,
        evaporates,
        releases[:, :k],
    )
    substeps = releases.shape[0]
    for j in range(k):
        total = 0.0
        for i in range(substeps):
            total += releases[i, j]
        mean_release[j] = total / substeps


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

    Returns:
        ``(days + 1, points)``; the last row is 0 (nothing is scored after the episode).
    """
    days = exogenous.shape[0]
    area, lmin = lake[0], lake[1]
    values = np.zeros((days + 1, points))
    width = decisions.shape[1]
    releases = np.empty((substeps, width))
    after = np.empty(width)
    mean_release = np.empty(width)
    for t in range(days - 1, -1, -1):
        demand, inflow, min_flow, evaporation, weight = exogenous[t]
        k = counts[t]
        for g in range(points):
            storage = area * (low + g * step - lmin)
            _days(storage, decisions[t, :k], inflow, evaporation, lake, evaporates, releases, after, mean_release)
            best = -np.inf
            for j in range(k):
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
    releases = np.empty((substeps, k))
    after = np.empty(k)
    mean_release = np.empty(k)
    _days(storage, decisions, inflow, evaporation, lake, evaporates, releases, after, mean_release)
    area, lmin = lake[0], lake[1]
    best, index = -np.inf, 0
    for j in range(k):
        level = after[j] / area + lmin
        value = _reward(mean_release[j], level, demand, min_flow, weight, costs)
        value += _value(values[t + 1], low, step, level)
        if value > best:
            best, index = value, j
    return index
