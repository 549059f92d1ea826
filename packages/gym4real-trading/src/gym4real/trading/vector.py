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
from gym4real.core.vector import check_max_episode_steps, copy_generators
from gym4real.trading.config import TradingConfig
from gym4real.trading.env import ACTIONS, FLAT, TradingEnv


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
        self._needs_reset = False
        self._days = np.zeros(num_envs, dtype=np.int64)
        self._load(self._days)

    def _load(self, days: np.ndarray) -> None:
        s = self.single
        feats = s._features[days[:, None], s._obs_rows[None, :]]  # (N, T+1, D-1)
        self._obs = np.concatenate([feats, np.zeros((*feats.shape[:2], 1), dtype=feats.dtype)], axis=2)
        self._mid = s.data.mid[days[:, None], s._price_rows[None, :]]
        self._k = 0
        self._pos = np.zeros(self.num_envs, dtype=np.int64)
        self.cum_pnl = np.zeros(self.num_envs)
        self.cum_fees = np.zeros(self.num_envs)

    def _observe(self, column: np.ndarray | int) -> np.ndarray:
        obs = self._obs[:, self._k].copy()
        obs[:, -1] = column
        return obs

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Draw a day per copy, as the single env seeded with ``seed + i`` (or continuing without a seed)."""
        super().reset(seed=seed)
        n = len(self.single.days)
        if self.single.config.sequential:
            self._days = (seed + self._rows) % n if seed is not None else (self._days + 1) % n
        else:
            self._rngs = copy_generators(self, self._rngs, seed)
            self._days = np.array([int(rng.integers(n)) for rng in self._rngs])
        self._load(self._days)
        self._needs_reset = False
        return self._observe(FLAT), {"day": self._days.copy()}

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Hold each copy's position over the next interval; close every copy at the end of the day."""
        n, s = self.num_envs, self.single
        if self._needs_reset:
            obs, info = self.reset()
            return obs, np.zeros(n), np.zeros(n, dtype=bool), np.zeros(n, dtype=bool), info
        a = discrete_actions(actions, self.single_action_space, n, ACTIONS)
        k = self._k
        pos = a - 1
        pnl = s._cap * pos * (self._mid[:, k + 1] - self._mid[:, k])
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
        info = {"reward_components": {"pnl": pnl, "fees": -fee}}
        return obs, pnl - fee, np.full(n, closed and s._terminate), np.full(n, done), info
