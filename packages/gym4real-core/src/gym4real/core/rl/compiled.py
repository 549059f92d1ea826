"""The episode loop of tabular Q-learning and SARSA in compiled code (numba, extra ``rl``).

It runs the dynamics an environment offers as compiled functions (its ``tabular_kernel()``: ``step`` and
``observe``, see :mod:`gym4real.core.rl.tabular`) and does exactly what the Python loop of
:func:`gym4real.core.rl.tabular.train_tabular` does, number for number.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit


@njit(cache=True)
def _choose(q: np.ndarray, s: int, u: np.ndarray, k: int, eps: float) -> int:
    n = q.shape[1]
    if eps > 0.0 and u[k] < eps:
        return min(int(u[k] / eps * n), n - 1)
    best = 0
    for a in range(1, n):
        if q[s, a] > q[s, best]:
            best = a
    return best


@njit(cache=True)
def _index(obs: np.ndarray, weights: np.ndarray) -> int:
    s = 0
    for i in range(obs.size):
        s += obs[i] * weights[i]
    return s


@njit
def run_episode(
    step: Callable[..., Any],
    observe: Callable[..., Any],
    state: np.ndarray,
    data: tuple[Any, ...],
    q: np.ndarray,
    weights: np.ndarray,
    u: np.ndarray,
    eps: float,
    alpha: float,
    gamma: float,
    sarsa: bool,
    learn: bool,
) -> tuple[float, int]:
    """Run one episode from ``state`` (epsilon-greedy on ``q``, updating it when ``learn``).

    Returns the episode's return and its number of steps.
    """
    obs = np.zeros(weights.size, dtype=np.int64)
    observe(state, data, obs)
    s = _index(obs, weights)
    a = _choose(q, s, u, 0, eps)
    k = 1
    total = 0.0
    while True:
        reward, terminated, truncated = step(state, data, a)
        observe(state, data, obs)
        s2 = _index(obs, weights)
        a2 = _choose(q, s2, u, k, eps)
        k += 1
        if learn:
            if terminated:
                target = reward
            elif sarsa:
                target = reward + gamma * q[s2, a2]
            else:
                target = reward + gamma * np.max(q[s2])
            q[s, a] += alpha * (target - q[s, a])
        total += reward
        if terminated or truncated:
            return total, k - 1
        s, a = s2, a2
