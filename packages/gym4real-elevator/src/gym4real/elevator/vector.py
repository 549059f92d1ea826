"""A native batched ElevatorEnv: N copies stepped together with numpy (corrected dynamics only)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from gym4real.core.actions import discrete_actions
from gym4real.core.vector import check_max_episode_steps, compiled_kernel, copy_generators, with_masks
from gym4real.elevator import arrivals
from gym4real.elevator.config import ElevatorConfig
from gym4real.elevator.env import ACTIONS, DOWN, OPEN, UP, ElevatorEnv


class ElevatorVectorEnv(VectorEnv[dict[str, Any], np.ndarray, np.ndarray]):
    """``num_envs`` copies of :class:`ElevatorEnv` in arrays, with the same dynamics step by step.

    Copy ``i`` of ``reset(seed=s)`` is the single env reset with seed ``s + i``, and it keeps that env's
    generator: ``reset()`` and autoresets continue it as the single env does without a seed, so the
    batch is a drop-in replacement for ``SyncVectorEnv`` of the single env. Every copy has the same
    episode length, so all copies end together; the step after the end resets them all (Gymnasium's
    next-step autoreset, with zero reward). Only ``fidelity="corrected"`` is batched.

    Made with ``gymnasium.make_vec("gym4real/elevator-v0", num_envs=N, vectorization_mode="vector_entry_point")``
    or directly, with the same arguments as the single env; ``max_episode_steps`` truncates every copy
    after that many steps, as Gymnasium's ``TimeLimit`` does to the single env. With numba installed (the
    extra ``fast``) the copies step in one compiled loop; ``compiled=False`` uses numpy instead (the same
    numbers), ``compiled=True`` requires numba.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        config: ElevatorConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        max_episode_steps: int | None = None,
        compiled: bool | None = None,
        **overrides: Any,
    ) -> None:
        self.single = ElevatorEnv(config, preset=preset, **overrides)
        self.max_episode_steps = check_max_episode_steps(max_episode_steps)
        self.config = cfg = self.single.config
        if cfg.fidelity != "corrected":
            raise ValueError(
                'the batched elevator supports fidelity="corrected" only; for upstream use '
                "gymnasium.make_vec(..., vectorization_mode='sync')"
            )
        self.num_envs = num_envs
        self.single_observation_space = self.single.observation_space
        self.single_action_space = self.single.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = spaces.MultiDiscrete(np.full(num_envs, 3))
        s = self.single
        self._served = np.array(s._served_floors, dtype=np.int64)
        self._limits = (int(s._top), int(s._ppf), int(s._goal), int(s._cap), int(s._max_q))
        self._kernel = compiled_kernel(
            "gym4real.elevator.vector_kernel", "step_copies", compiled, "pip install gym4real-elevator[fast]"
        )
        self._rows = np.arange(num_envs)
        self._rngs: list[np.random.Generator] | None = None
        self._needs_reset = False
        self._reset_arrays(
            np.zeros((num_envs, cfg.duration + 1, len(self._served)), dtype=np.int8), np.zeros(num_envs, dtype=np.int64)
        )

    def _reset_arrays(self, table: np.ndarray, position: np.ndarray) -> None:
        n = self.num_envs
        self._arrivals = table
        self._t = 0
        self._pos = position
        self._load = np.zeros(n, dtype=np.int64)
        self._queues = np.zeros((n, self.single._n_floors), dtype=np.int64)
        self.delivered = np.zeros(n, dtype=np.int64)
        self.turned_away = np.zeros(n, dtype=np.int64)

    def _obs(self) -> dict[str, np.ndarray]:
        return {
            "arrivals": self._arrivals[:, self._t].astype(np.int64),
            "current_position": self._pos.copy(),
            "floor_queues": self._queues[:, self._served],
            "n_passengers": self._load.copy(),
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Reset every copy: copy ``i`` seeded with ``seed + i``, or continuing its generator without a seed."""
        super().reset(seed=seed)
        cfg, f, s = self.config, self.config.floors, self.single
        table = np.empty_like(self._arrivals)
        position = np.empty(self.num_envs, dtype=np.int64)
        self._rngs = copy_generators(self, self._rngs, seed)
        for i, rng in enumerate(self._rngs):
            rates = arrivals.draw_rates(rng, len(self._served), f.lambda_min, f.lambda_max)
            arrivals.corrected_arrivals(
                rng, rates, cfg.duration, f.max_arrivals, out=table[i, :-1], compiled=self._kernel is not None
            )
            table[i, -1] = 0
            if cfg.init_elevator_pos is not None:
                position[i] = round(cfg.init_elevator_pos / cfg.elevator.movement_speed)
            else:
                position[i] = rng.integers(s._top + 1)
        self._reset_arrays(table, position)
        self._needs_reset = False
        return self._obs(), {}

    def _step_numpy(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Move, open and let last second's arrivals join, in numpy; the passengers served and aboard or waiting."""
        s = self.single
        pos, load, queues = self._pos, self._load, self._queues
        pos += (a == UP) & (pos < s._top)
        pos -= (a == DOWN) & (pos > 0)
        open_ = (a == OPEN) & (pos % s._ppf == 0)
        floor = pos // s._ppf
        served = np.where(open_ & (floor == s._goal), load, 0)
        load -= served
        waiting_here = queues[self._rows, floor]
        board = np.where(open_, np.minimum(s._cap - load, waiting_here), 0)
        queues[self._rows, floor] = waiting_here - board
        load += board
        people = load + queues.sum(axis=1)
        k = self._arrivals[:, self._t]
        room = s._max_q - queues[:, self._served]
        join = np.minimum(k, room)
        queues[:, self._served] += join
        self.turned_away += (k - join).sum(axis=1)
        return served, people

    def _step_compiled(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`_step_numpy` as one compiled loop over the copies (the same integers)."""
        n = self.num_envs
        served, people = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
        self._kernel(
            a,
            self._pos,
            self._load,
            self._queues,
            self._arrivals[:, self._t],
            self._served,
            self._limits,
            served,
            people,
            self.turned_away,
        )
        return served, people

    def step(
        self, actions: np.ndarray
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every copy with the same rules as :meth:`ElevatorEnv.step`."""
        n = self.num_envs
        if self._needs_reset:
            obs, info = self.reset()
            return obs, np.zeros(n), np.zeros(n, dtype=bool), np.zeros(n, dtype=bool), info
        a = discrete_actions(actions, self.single_action_space, n, ACTIONS)
        s = self.single
        served, people = (self._step_compiled if self._kernel is not None else self._step_numpy)(a)
        self.delivered += served
        delivery = s._coeff * served
        people = people.astype(float)
        waiting = -people if s._always_wait_penalty else np.where(served > 0, 0.0, -people)
        self._t += 1
        done = self._t >= self.config.duration or self._t == self.max_episode_steps
        self._needs_reset = done
        info = {"reward_components": {"delivery": delivery.astype(float), "waiting": waiting}}
        return self._obs(), delivery + waiting, np.zeros(n, dtype=bool), np.full(n, done), with_masks(info, n)
