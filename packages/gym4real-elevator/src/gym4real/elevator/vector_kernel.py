"""The batched elevator's move-board-arrive step as one compiled loop over the copies (numba).

:class:`~gym4real.elevator.vector.ElevatorVectorEnv` runs :func:`step_copies` when numba is installed (the
extra ``fast``) and the same rules in numpy otherwise; every quantity is an integer, so both give the same
numbers (a test steps both side by side).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gym4real.elevator.env import DOWN, OPEN, UP


@njit(cache=True)
def step_copies(
    actions: np.ndarray,
    pos: np.ndarray,
    load: np.ndarray,
    queues: np.ndarray,
    arrivals: np.ndarray,
    served_floors: np.ndarray,
    limits: tuple[int, int, int, int, int],
    served: np.ndarray,
    people: np.ndarray,
    turned_away: np.ndarray,
) -> None:
    """One step of every copy, in place: move, open (deliver at the goal, board), then last second's arrivals join.

    Args:
        actions: One action per copy (``DOWN``, ``OPEN`` or ``UP``).
        pos: Each copy's position (in movement steps), updated.
        load: Each copy's passengers aboard, updated.
        queues: Each copy's queue per floor ``(copies, floors)``, updated.
        arrivals: This second's arrivals per copy and served floor.
        served_floors: The floor of each column of ``arrivals``.
        limits: Top position, positions per floor, goal floor, cabin capacity, queue capacity.
        served: Out: passengers delivered per copy.
        people: Out: passengers aboard and waiting per copy, after boarding and before the arrivals.
        turned_away: Incremented by the arrivals that found their queue full.
    """
    top, ppf, goal, cap, max_q = limits
    for i in range(actions.size):
        action, p = actions[i], pos[i]
        if action == UP and p < top:
            p += 1
        elif action == DOWN and p > 0:
            p -= 1
        pos[i] = p
        delivered = 0
        if action == OPEN and p % ppf == 0:
            floor = p // ppf
            if floor == goal:
                delivered = load[i]
                load[i] = 0
            board = min(cap - load[i], queues[i, floor])
            queues[i, floor] -= board
            load[i] += board
        served[i] = delivered
        total = load[i]
        for floor in range(queues.shape[1]):
            total += queues[i, floor]
        people[i] = total
        for j in range(served_floors.size):
            k = arrivals[i, j]
            floor = served_floors[j]
            join = min(k, max_q - queues[i, floor])
            queues[i, floor] += join
            turned_away[i] += k - join
