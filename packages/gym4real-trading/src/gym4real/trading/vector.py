"""A native batched TradingEnv: N copies stepped together with numpy, same dynamics as the single env."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from gym4real.core.actions import discrete_actions
from gym4real.core.vector import check_max_episode_steps, copy_generators, per_copy, with_masks
from gym4real.trading.config import TradingConfig
from gym4real.trading.env import ACTIONS, FLAT, TradingEnv

DRAWS_AT_ONCE = 256  # random days drawn per copy and call (see TradingVectorEnv._draw_days)


class TradingVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """``num_envs`` copies of :class:`TradingEnv` sharing one loaded data split.

    Copy ``i`` of ``reset(seed=s)`` trades the day the single env picks for ``reset(seed=s + i)`` and keeps
    that env's generator; every day has the same number of decisions, so all copies close together and
    the next step resets them (Gymnasium's next-step autoreset, zero reward) to the day each single env
    would pick without a seed: the batch is a drop-in replacement for ``SyncVectorEnv`` of the single env.
    Made with ``gymnasium.make_vec("gym4real/trading-v0", num_envs=N, vectorization_mode="vector_entry_point")``
    or directly, with the single env's arguments; ``max_episode_steps`` truncates every copy after that
    many steps, as Gymnasium's ``TimeLimit`` does to the single env.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        config: TradingConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        max_episode_steps: int | None = None,
        **overrides: Any,
    ) -> None:
        self.single = s = TradingEnv(config, preset=preset, **overrides)
        self.max_episode_steps = check_max_episode_steps(max_episode_steps)
        self.num_envs = num_envs
        self.single_observation_space = s.observation_space
        self.single_action_space = s.action_space
        self.observation_space = batch_space(s.observation_space, num_envs)
        self.action_space = spaces.MultiDiscrete(np.full(num_envs, 3))
        self._rows = np.arange(num_envs)
        self._rngs: list[np.random.Generator] | None = None
        self._drawn = np.empty((num_envs, 0), dtype=np.int64)  # each copy's random days drawn ahead, in order
        self._needs_reset = False
        # per day of the split: the observations (the position column left 0) and the price moves of each step
        feats = s._features[:, s._obs_rows]
        self._day_obs = np.concatenate([feats, np.zeros((*feats.shape[:2], 1), dtype=feats.dtype)], axis=2)
        mid = s.data.mid[:, s._price_rows]
        self._day_moves = mid[:, 1:] - mid[:, :-1]
        self._load(np.zeros(num_envs, dtype=np.int64))

    def _load(self, days: np.ndarray) -> None:
        self._days = days
        self._k = 0
        self._pos = np.zeros(self.num_envs, dtype=np.int64)
        self.cum_pnl = np.zeros(self.num_envs)
        self.cum_fees = np.zeros(self.num_envs)

    def _observe(self, column: np.ndarray | int) -> np.ndarray:
        obs = self._day_obs[self._days, self._k]  # a new array
        obs[:, -1] = column
        return obs

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Draw a day per copy, as the single env seeded with ``seed + i`` (or continuing without a seed).

        Args:
            seed: Copy ``i`` starts as the single env reset with ``seed + i``; None continues each copy.
            options: ``day`` as in the single env (a date, ``YYYY-MM-DD`` or an index into ``days``), one
                for every copy or one per copy; no day is drawn then, as in the single env.

        Returns:
            The observations and an info dict with each copy's ``day`` (an index into ``single.days``).
        """
        super().reset(seed=seed)
        s = self.single
        options = dict(options or {})
        unknown = sorted(set(options) - {"day"})
        if unknown:
            raise ValueError(f"unknown reset options {unknown}; expected some of ['day']")
        n = len(s.days)
        if not s.config.sequential and (seed is not None or self._rngs is None):
            self._rngs = copy_generators(self, self._rngs, seed)
            self._drawn = np.empty((self.num_envs, 0), dtype=np.int64)  # the new generators' days are not drawn yet
        if options.get("day") is not None:
            wanted = per_copy(options["day"], self.num_envs, "day").tolist()
            self._load(np.array([s._day_index(day) for day in wanted], dtype=np.int64))
        elif s.config.sequential:
            self._load((seed + self._rows) % n if seed is not None else (self._days + 1) % n)
        else:
            self._load(self._draw_days(n))
        self._needs_reset = False
        return self._observe(FLAT), with_masks({"day": self._days.copy()}, self.num_envs)

    def _draw_days(self, n: int) -> np.ndarray:
        """Each copy's next random day, taken from days drawn ``DRAWS_AT_ONCE`` at a time per copy.

        ``Generator.integers(n, size=k)`` yields the numbers of ``k`` successive ``integers(n)`` calls (the
        single env's draws), and the copies' generators draw nothing else: one call per copy every
        ``DRAWS_AT_ONCE`` resets instead of one per copy per reset.
        """
        if self._drawn.shape[1] == 0:
            self._drawn = np.stack([rng.integers(n, size=DRAWS_AT_ONCE) for rng in self._rngs or ()])
        days, self._drawn = self._drawn[:, 0], self._drawn[:, 1:]
        return days

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Hold each copy's position over the next interval; close every copy at the end of the day."""
        n, s = self.num_envs, self.single
        if self._needs_reset:
            obs, info = self.reset()
            return obs, np.zeros(n), np.zeros(n, dtype=bool), np.zeros(n, dtype=bool), info
        a = discrete_actions(actions, self.single_action_space, n, ACTIONS)
        k = self._k
        pos = a - 1
        pnl = s._cap * pos * self._day_moves[self._days, k]
        fee = s._fee * np.abs(pos - self._pos)
        self._k = k + 1
        closed = self._k == s.n_steps
        done = closed or self._k == self.max_episode_steps
        if closed:
            fee = fee + s._fee * np.abs(pos if s._close_new else self._pos)
            self._pos = np.zeros(n, dtype=np.int64)
            obs = self._observe(FLAT)
        else:
            self._pos = pos
            obs = self._observe(a)
        self.cum_pnl += pnl
        self.cum_fees += fee
        self._needs_reset = done
        info = with_masks({"reward_components": {"pnl": pnl, "fees": -fee}}, n)
        return obs, pnl - fee, np.full(n, closed and s._terminate), np.full(n, done), info
