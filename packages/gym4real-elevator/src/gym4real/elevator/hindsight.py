"""The elevator's hindsight planner: the best actions of an episode whose arrivals are known, by exact DP.

A non-causal upper reference (:mod:`gym4real.bench.upper_reference`), not a baseline: at the first step
of an episode it reads the episode's whole arrivals table from the environment (who appears at which
floor in every second, which no agent knows in advance) and solves the episode by backward dynamic
programming over the full state the dynamics depend on: the cabin's position, its load and the queue of
every served floor (9 x 5 x 4 ** 4 = 11,520 states with the paper's building). The arrivals do not
depend on the actions (they are drawn at reset; a full queue turns people away, which the state holds),
so the programme is exact: its value is the highest return of any action sequence. Each transition is
the environment's own compiled step (:func:`gym4real.elevator.kernel.step`, tested step for step against
:meth:`ElevatorEnv.step`), and the plan replayed through the environment scores the planned return
(``planned_objectives``).

Cost: ``duration x states x 3`` compiled steps, about 124 million for a one-hour episode.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from numba import njit

from gym4real.bench.upper_reference import PlanCache, plan_cache, plan_key
from gym4real.core.errors import ConfigError
from gym4real.elevator.env import ElevatorEnv
from gym4real.elevator.kernel import ElevatorKernel, step

#: The planner's version in its cache keys: bump it when a change alters the plans.
VERSION = "elevator-dp-1"
_T, _POS, _LOAD, _DELIVERED, _TURNED_AWAY, _QUEUES = range(6)


@njit(cache=True)
def _encode(state: np.ndarray, served: np.ndarray, cap: int, max_q: int) -> int:
    index = state[_POS] * (cap + 1) + state[_LOAD]
    for j in range(served.size):
        index = index * (max_q + 1) + state[_QUEUES + served[j]]
    return index


@njit(cache=True)
def _decode(index: int, state: np.ndarray, served: np.ndarray, cap: int, max_q: int) -> None:
    for j in range(served.size - 1, -1, -1):
        state[_QUEUES + served[j]] = index % (max_q + 1)
        index //= max_q + 1
    state[_LOAD] = index % (cap + 1)
    state[_POS] = index // (cap + 1)


@njit(cache=True)
def solve(
    table: np.ndarray,
    served: np.ndarray,
    params: np.ndarray,
    coeff: float,
    positions: int,
    floors: int,
    start: np.ndarray,
) -> tuple[np.ndarray, float]:
    """The best actions from ``start`` (a kernel state at t = 0) and their return, by backward induction.

    Args:
        table: The episode's arrivals per second and served floor (the env's table).
        served: The served floors (queue indices of the state).
        params: The kernel's integer parameters (:class:`ElevatorKernel`).
        coeff: The reward per delivered passenger.
        positions: The cabin positions (top + 1).
        floors: The number of floors (queue slots of the state).
        start: The state at the start of the episode.
    """
    cap, max_q, duration = params[3], params[4], params[5]
    states = positions * (cap + 1) * (max_q + 1) ** served.size
    later = np.zeros(states)
    now = np.empty(states)
    best_action = np.empty((duration, states), dtype=np.int8)
    state = np.zeros(_QUEUES + floors, dtype=np.int64)
    data = (table, served, params, coeff)
    for t in range(duration - 1, -1, -1):
        for index in range(states):
            best, chosen = -np.inf, 0
            for action in range(3):
                state[:] = 0
                state[_T] = t
                _decode(index, state, served, cap, max_q)
                reward, _, _ = step(state, data, action)
                value = reward + later[_encode(state, served, cap, max_q)]
                if value > best:
                    best, chosen = value, action
            now[index] = best
            best_action[t, index] = chosen
        later, now = now, later
    state[:] = start
    plan = np.empty(duration, dtype=np.int64)
    for t in range(duration):
        plan[t] = best_action[t, _encode(state, served, cap, max_q)]
        step(state, data, plan[t])
    state[:] = start
    return plan, later[_encode(state, served, cap, max_q)]


class ElevatorHindsight:
    """Plays the exact best actions of each episode (see the module docstring).

    Args:
        env: The elevator environment (``gymnasium.make`` output or raw); its current episode is planned.
        cache: Reuse plans from the user cache (:func:`gym4real.bench.upper_reference.plan_cache`).
    """

    def __init__(self, env: gym.Env[Any, Any], cache: bool = True) -> None:
        unwrapped = env.unwrapped
        if not isinstance(unwrapped, ElevatorEnv):
            raise ConfigError(f"the elevator's hindsight planner needs an ElevatorEnv, not {type(unwrapped).__name__}")
        self.env: ElevatorEnv = unwrapped
        self._kernel = ElevatorKernel(unwrapped)
        self._cache: PlanCache = plan_cache(env, VERSION) if cache else PlanCache(None)
        self._plan: list[int] = []
        self.planned_objectives: list[float] = []

    def reset(self, seed: int | None = None) -> None:
        """Forget the plan: the next call plans the episode the environment has just started."""
        self._plan = []

    def __call__(self, obs: Any) -> int:
        """The planned action (0 down, 1 open, 2 up) of the current second."""
        t = self.env._t
        if t == 0 or not self._plan:
            self._plan = self.plan()
        return self._plan[t]

    def plan(self) -> list[int]:
        """Plan the environment's current episode from its start; return the action of every second."""
        env = self.env
        if env._t != 0:
            raise ConfigError("the elevator's hindsight planner plans an episode from its start: reset the env first")
        table = np.ascontiguousarray(env._arrivals, dtype=np.int64)
        start = np.zeros(_QUEUES + env._n_floors, dtype=np.int64)
        start[_POS], start[_LOAD] = env._pos, env._load
        for floor in env._served_floors:
            start[_QUEUES + floor] = env._queues[floor]
        k = self._kernel
        key = plan_key(version=VERSION, table=table, start=start, params=k._params, coeff=k._coeff)
        found = self._cache.get(key)
        if found is None:
            plan, value = solve(table, k._served, k._params, k._coeff, env._top + 1, env._n_floors, start)
            found = {"actions": plan.tolist(), "planned": float(value)}
            self._cache.put(key, found)
        self.planned_objectives.append(float(found["planned"]))
        return [int(a) for a in found["actions"]]


def hindsight(env: gym.Env[Any, Any]) -> ElevatorHindsight:
    """Baseline factory: the non-causal hindsight planner (exact dynamic programming with the known arrivals)."""
    return ElevatorHindsight(env)
