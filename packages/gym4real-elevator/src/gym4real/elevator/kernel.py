"""ElevatorEnv's step as compiled code (numba), for tabular learning at compiled speed.

:class:`ElevatorKernel` holds one reset episode of an :class:`~gym4real.elevator.env.ElevatorEnv` as arrays
and offers the functions that :mod:`gym4real.rl.tabular` runs in its compiled loop: ``step`` (the
env's ``step``, both fidelity modes) and ``observe`` (the observation flattened in sorted-key order, as
the tabular state index reads it). Tests step it against the env.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from numba import njit

if TYPE_CHECKING:
    from gym4real.elevator.env import ElevatorEnv

# state vector: time, position, load, delivered, turned away, then one queue per floor
_T, _POS, _LOAD, _DELIVERED, _TURNED_AWAY, _QUEUES = range(6)
# integer parameters
_TOP, _PPF, _GOAL, _CAP, _MAX_Q, _DURATION, _UPSTREAM, _ALWAYS_WAIT = range(8)
_DOWN, _OPEN, _UP = 0, 1, 2


@njit(cache=True)
def step(state: np.ndarray, data: tuple[Any, ...], action: int) -> tuple[float, bool, bool]:
    """One step of :meth:`ElevatorEnv.step` on ``state`` (updated in place); returns reward, terminated, truncated."""
    table, served_floors, p, coeff = data
    if action == _UP and state[_POS] < p[_TOP]:
        state[_POS] += 1
    elif action == _DOWN and state[_POS] > 0:
        state[_POS] -= 1
    served = 0
    if action == _OPEN and (p[_UPSTREAM] == 1 or state[_POS] % p[_PPF] == 0):
        floor = state[_POS] // p[_PPF]
        if floor == p[_GOAL]:
            served = state[_LOAD]
            state[_LOAD] = 0
            state[_DELIVERED] += served
        board = min(p[_CAP] - state[_LOAD], state[_QUEUES + floor])
        state[_QUEUES + floor] -= board
        state[_LOAD] += board
    waiting = 0.0
    if served == 0 or p[_ALWAYS_WAIT] == 1:
        people = state[_LOAD]
        for i in range(state.size - _QUEUES):
            people += state[_QUEUES + i]
        waiting = -float(people)
    t = state[_T]
    for j in range(served_floors.size):
        k = table[t, j]
        if k > 0:
            floor = served_floors[j]
            wanting = (k + 1) // 2 if p[_UPSTREAM] == 1 else k
            join = min(wanting, p[_MAX_Q] - state[_QUEUES + floor])
            state[_QUEUES + floor] += join
            state[_TURNED_AWAY] += k - join
    state[_T] = t + 1
    done = state[_T] >= p[_DURATION]
    return coeff * served + waiting, done and p[_UPSTREAM] == 1, done and p[_UPSTREAM] == 0


@njit(cache=True)
def observe(state: np.ndarray, data: tuple[Any, ...], obs: np.ndarray) -> None:
    """Write the observation into ``obs`` in sorted-key order: arrivals, position, queues, passengers."""
    table, served_floors = data[0], data[1]
    n = served_floors.size
    for j in range(n):
        obs[j] = table[state[_T], j]
    obs[n] = state[_POS]
    for j in range(n):
        obs[n + 1 + j] = state[_QUEUES + served_floors[j]]
    obs[2 * n + 1] = state[_LOAD]


class ElevatorKernel:
    """An :class:`ElevatorEnv`'s episodes as arrays for :func:`step` and :func:`observe`."""

    step = staticmethod(step)
    observe = staticmethod(observe)

    def __init__(self, env: ElevatorEnv) -> None:
        self.horizon = env._duration
        self._params = np.array(
            [
                env._top,
                env._ppf,
                env._goal,
                env._cap,
                env._max_q,
                env._duration,
                int(env._upstream),
                int(env._always_wait_penalty),
            ],
            dtype=np.int64,
        )
        self._served = np.array(env._served_floors, dtype=np.int64)
        self._coeff = float(env._coeff)

    def reset(self, env: ElevatorEnv, seed: int | None) -> tuple[np.ndarray, tuple[Any, ...]]:
        """The arrays of the episode ``env.reset(seed=seed)`` starts, drawn as it draws them; ``env`` itself stays.

        Skips what the Python ``step`` needs (lists of the arrivals), the larger part of a reset's cost.
        """
        gym.Env.reset(env, seed=seed)
        table, position = env._draw_episode()
        state = np.zeros(_QUEUES + env._n_floors, dtype=np.int64)
        state[_POS] = position
        return state, (table, self._served, self._params, self._coeff)
