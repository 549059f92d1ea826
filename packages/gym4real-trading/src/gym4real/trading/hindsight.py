"""Trading's hindsight planner: the best positions of a day whose prices are known, by exact dynamic programming.

A non-causal upper reference (:mod:`gym4real.bench.upper_reference`), not a baseline: at the first step
of a trading day it reads the day's prices at every decision (which no agent knows in advance) and the
episode's fee from the environment, and finds the sequence of positions of highest daily P&L net of fees,
the protocol's objective (``pnl + fees``).

The state is the position held before a decision (short, flat or long); decision ``k`` earns
``capital * position * (p[k+1] - p[k]) - fee * |position - previous|`` and the last one also pays the
forced close, ``fee * |position|`` (or, with ``fidelity="upstream"``, ``fee * |previous|``), as
:meth:`TradingEnv.step` computes them. Backward induction over the three positions is exact: the plan's
objective is the maximum over all ``3 ** n`` position sequences (a test checks it against them all), and
replaying it through the environment scores it exactly (``planned_objectives`` equals the replayed
objective up to float rounding).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.errors import ConfigError
from gym4real.trading.env import FLAT, TradingEnv

POSITIONS = (-1, 0, 1)


def plan_day(
    prices: list[float] | np.ndarray, capital: float, fee: float, close_new: bool = True
) -> tuple[list[int], float]:
    """The best positions of a day and their objective (P&L minus fees, USD).

    Args:
        prices: The mid price at each decision and after the last one (``n + 1`` values for ``n`` decisions).
        capital: The notional of a position.
        fee: The fee per unit of position change.
        close_new: Charge the forced close on the last position taken (the corrected env); False: on the
            position held before it (``fidelity="upstream"``).

    Returns:
        The positions (-1, 0 or 1) of the ``n`` decisions, and their total objective.
    """
    p = np.asarray(prices, dtype=float)
    n = len(p) - 1
    if n < 1 or not np.all(np.isfinite(p)):
        raise ConfigError(f"a trading day needs at least 2 finite prices, got {p.tolist()}")
    # value[k][i]: best objective of decisions k..n-1 holding POSITIONS[i] before decision k
    value = np.zeros((n + 1, 3))
    best = np.zeros((n, 3), dtype=np.int64)
    for k in range(n - 1, -1, -1):
        for i, prev in enumerate(POSITIONS):
            returns = []
            for pos in POSITIONS:
                r = capital * pos * (p[k + 1] - p[k]) - fee * abs(pos - prev)
                if k == n - 1:
                    r -= fee * abs(pos if close_new else prev)
                    returns.append(r)
                else:
                    returns.append(r + value[k + 1][pos + 1])
            j = int(np.argmax(returns))  # ties: the first (short before flat before long)
            best[k, i], value[k, i] = j, returns[j]
    positions, held = [], 0
    for k in range(n):
        held = POSITIONS[best[k, held + 1]]
        positions.append(held)
    return positions, float(value[0, 1])


class TradingHindsight:
    """Plays the exact best positions of each trading day (see the module docstring).

    Args:
        env: The trading environment (``gymnasium.make`` output or raw); its current day is planned.
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        unwrapped = env.unwrapped
        if not isinstance(unwrapped, TradingEnv):
            raise ConfigError(f"trading's hindsight planner needs a TradingEnv, not {type(unwrapped).__name__}")
        self.env: TradingEnv = unwrapped
        self._plan: list[int] = []
        self.planned_objectives: list[float] = []

    def reset(self, seed: int | None = None) -> None:
        """Forget the plan: the next call plans the day the environment has just started."""
        self._plan = []

    def __call__(self, obs: Any) -> int:
        """The planned action (0 short, 1 flat, 2 long) of the current decision."""
        env = self.env
        k = env._k
        if k == 0 or not self._plan:
            positions, objective = plan_day(env._mid, env._cap, env._episode_fee, env._close_new)
            self._plan = positions
            self.planned_objectives.append(objective)
        return FLAT + self._plan[k]


def hindsight(env: gym.Env[Any, Any]) -> TradingHindsight:
    """Baseline factory: the non-causal hindsight planner (exact dynamic programming over the position)."""
    return TradingHindsight(env)
