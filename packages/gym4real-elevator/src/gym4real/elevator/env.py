"""ElevatorEnv: one elevator dispatching passengers to the ground floor during peak-down traffic."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from gym4real.core.actions import DiscreteAction
from gym4real.elevator import arrivals
from gym4real.elevator.config import ElevatorConfig

if TYPE_CHECKING:
    from gym4real.elevator.rendering import ElevatorRenderer

DOWN, OPEN, UP = 0, 1, 2
ACTIONS = "0 (down), 1 (open) or 2 (up)"


class ElevatorEnv(gym.Env[dict[str, Any], int]):
    """A single elevator serving a building during peak-down traffic (Gym4ReaL ``ElevatorEnv``).

    ## Description
    Passengers appear at floors 1..4 by per-floor Poisson processes whose rates are drawn uniformly in
    ``[lambda_min, lambda_max]`` at each reset, and all want to reach the ground floor. Each step is one
    second; the cabin moves ``movement_speed`` metres (two steps per floor by default). Queues hold at
    most ``max_queue_length`` people (more arrivals balk) and the cabin ``max_capacity``.

    ## Action Space
    ``Discrete(3)``: 0 move down, 1 stay and open the doors (unload at the goal floor, then board first
    in first out), 2 move up. Moving past the top or bottom floor is a no-op.

    ## Observation Space
    ``Dict``:

    | key | space | meaning |
    |---|---|---|
    | ``current_position`` | ``Discrete(9)`` | height / speed (even: at a floor) |
    | ``n_passengers`` | ``Discrete(5)`` | people in the cabin |
    | ``floor_queues`` | ``MultiDiscrete([4] * 4)`` | people waiting at floors 1..4 |
    | ``arrivals`` | ``MultiDiscrete([3] * 4)`` | people who appeared this second, queued next second |

    ## Rewards
    ``reward_coeff`` (10) per delivered passenger in steps that deliver; otherwise minus the people
    waiting and riding. ``info["reward_components"]`` holds ``delivery`` and ``waiting``.

    ## Starting State
    Empty cabin and queues; the cabin at ``init_elevator_pos`` or, when null, at a uniformly drawn
    position (possibly between floors, as in the reference).

    ## Episode End
    Truncation after ``duration`` (3600) steps. There is no termination.

    ## Arguments
    ``gymnasium.make("gym4real/elevator-v0", config=None, preset=None, render_mode=None, **overrides)``:
    ``config`` is an :class:`ElevatorConfig`, a mapping or a YAML path; ``preset`` is ``"default"`` or
    ``"test"``; overrides are config fields (``fidelity="upstream"``, ``reward_coeff=5.0``, ...).
    ``render_mode="ansi"`` draws the shaft in text, ``"rgb_array"`` in 480 x 320 frames (floors, cabin and
    load, the queue at each floor, deliveries so far).

    ## Corrected mode and ``fidelity="upstream"``
    The default mode fixes the reference's defects; ``fidelity="upstream"`` restores them:

    1. Doors: corrected, they open only at a floor (between floors action 1 stays still); upstream they
       open anywhere and serve the floor below.
    2. Queue transfer: corrected, last second's arrivals join the queue until it is full and only the
       excess balks; upstream, the list-mutation bug lets only every other arrival join.
    3. Seeding: corrected, all randomness (rates, arrivals, start) comes from ``reset(seed=)`` with an
       independent stream per floor; upstream, the rates come from a generator seeded once with
       ``floors.seed``, every floor's arrivals restart from ``floors.seed``, and the start is drawn from
       the observation space (seeded here with ``floors.seed``, so it is repeatable).
    4. Time limit: corrected ``truncated``; upstream ``terminated``.

    Both modes return numpy arrays (the reference returns a list for ``arrivals``) and take the queue
    floors relative to ``goal_floor``. ``waiting_penalty_on_delivery`` optionally charges the waiting
    penalty in delivery steps too (the reference does not, in either mode).

    ## Version History
    * v0: Gym4ReaL v1.0 dynamics, corrected by default.
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 8}
    reward_component_names = ("delivery", "waiting")

    def __init__(
        self,
        config: ElevatorConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        self.config = cfg = ElevatorConfig.build(config, preset, **overrides)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, not {render_mode!r}")
        self.render_mode = render_mode
        e, f = cfg.elevator, cfg.floors
        self._upstream = cfg.fidelity == "upstream"
        self._ppf = round(e.floor_height / e.movement_speed)  # positions per floor
        self._n_floors = e.max_floor - e.min_floor + 1
        self._top = (self._n_floors - 1) * self._ppf
        self._goal = cfg.goal_floor - e.min_floor
        self._served_floors = [i for i in range(self._n_floors) if i != self._goal]
        self._cap = e.max_capacity
        self._max_q = f.max_queue_length
        self._speed = e.movement_speed
        self._duration = cfg.duration
        self._coeff = cfg.reward_coeff
        self._always_wait_penalty = cfg.waiting_penalty_on_delivery
        self._obs_index = {floor: i for i, floor in enumerate(self._served_floors)}
        n = len(self._served_floors)
        self._renderer: ElevatorRenderer | None = None
        if render_mode == "rgb_array":
            from gym4real.elevator.rendering import ElevatorRenderer

            self._renderer = ElevatorRenderer(
                self._n_floors, self._ppf, self._goal, e.min_floor, self._cap, cfg.duration
            )

        self._position_space = spaces.Discrete(self._top + 1)
        self.action_space = spaces.Discrete(3)  # type: ignore[assignment]
        self._action = DiscreteAction(self.action_space, ACTIONS)
        self.observation_space = spaces.Dict(
            {
                "arrivals": spaces.MultiDiscrete([f.max_arrivals + 1] * n),
                "current_position": self._position_space,
                "floor_queues": spaces.MultiDiscrete([f.max_queue_length + 1] * n),
                "n_passengers": spaces.Discrete(e.max_capacity + 1),
            }
        )
        if self._upstream:
            self._rate_rng = np.random.default_rng(f.seed)
            self._position_space.seed(f.seed)
        self._reset_state(np.zeros((cfg.duration + 1, n), dtype=np.int64), 0)

    # -- state -------------------------------------------------------------------------------------

    def _reset_state(self, arrivals_table: np.ndarray, position: int) -> None:
        self._arrivals = arrivals_table
        # the observations' arrivals: row t is handed out once, at second t (the dynamics read _rows), so
        # the agent may keep or change it without touching the episode
        self._arrival_obs = arrivals_table.copy()
        per_second = arrivals_table @ np.ones(arrivals_table.shape[1], dtype=np.int64)  # faster than sum(axis=1)
        self._arrived_cum = np.cumsum(per_second)
        seconds = np.flatnonzero(per_second)
        # the seconds with arrivals (about a fifth) as Python ints: the step's hot path reads no numpy
        self._rows = dict(zip(seconds.tolist(), arrivals_table[seconds].tolist(), strict=True))
        self._any_arrival = (per_second > 0).tolist()  # the step's test: a list index is faster than `in _rows`
        self._no_arrivals = [0] * arrivals_table.shape[1]
        self._t = 0
        self._pos = position
        self._load = 0
        self._queues = [0] * self._n_floors
        self._waiting = 0  # sum(self._queues), kept as they change
        self._queue_obs = np.zeros(len(self._served_floors), dtype=np.int64)  # mirror of the served queues
        self.delivered = 0
        self.turned_away = 0
        if self._renderer is not None:
            self._renderer.start()

    def _futures(self) -> list[int]:
        """This second's arrivals per served floor: they join the queues at the end of the next step."""
        return self._rows.get(self._t, self._no_arrivals)

    def _obs(self) -> dict[str, Any]:
        return {
            "arrivals": self._arrival_obs[self._t],
            "current_position": self._pos,
            "floor_queues": self._queue_obs.copy(),
            "n_passengers": self._load,
        }

    def counts(self) -> dict[str, int]:
        """Passenger accounting: arrived = waiting + riding + delivered + turned_away + pending."""
        return {
            "arrived": int(self._arrived_cum[self._t]),
            "waiting": self._waiting,
            "riding": self._load,
            "delivered": self.delivered,
            "turned_away": self.turned_away,
            "pending": sum(self._futures()),
        }

    def _info(self, components: dict[str, float]) -> dict[str, Any]:
        return {
            "time": self._t,
            "position_m": self._pos * self._speed,
            "delivered": self.delivered,
            "turned_away": self.turned_away,
            "reward_components": components,
            "cost": 0.0,
        }

    # -- gymnasium API -----------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode: new arrival rates and arrivals, empty cabin and queues."""
        super().reset(seed=seed)
        table, position = self._draw_episode()
        self._reset_state(table, position)
        return self._obs(), self._info({"delivery": 0.0, "waiting": 0.0})

    def _draw_episode(self) -> tuple[np.ndarray, int]:
        """Draw a new episode's rates (kept in ``rates``), arrivals table (with a closing row of zeros) and start."""
        cfg, f = self.config, self.config.floors
        n = len(self._served_floors)
        if self._upstream:
            rates = arrivals.draw_rates(self._rate_rng, n, f.lambda_min, f.lambda_max)
            table = arrivals.upstream_arrivals(f.seed, rates, cfg.duration, f.max_arrivals)
        else:
            rates = arrivals.draw_rates(self.np_random, n, f.lambda_min, f.lambda_max)
            table = arrivals.corrected_arrivals(self.np_random, rates, cfg.duration, f.max_arrivals)
        if cfg.init_elevator_pos is not None:
            position = round(cfg.init_elevator_pos / cfg.elevator.movement_speed)
        elif self._upstream:
            position = int(self._position_space.sample())
        else:
            position = int(self.np_random.integers(self._top + 1))
        self.rates = rates
        return np.vstack([table, np.zeros((1, n), dtype=np.int64)]), position

    def step(self, action: int) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """Move or open the doors, then let last second's arrivals join the queues."""
        action = self._action(action)
        if action == UP:
            if self._pos < self._top:
                self._pos += 1
        elif action == DOWN and self._pos > 0:
            self._pos -= 1

        served = 0
        if action == OPEN and (self._upstream or self._pos % self._ppf == 0):
            floor = self._pos // self._ppf
            if floor == self._goal:
                served, self._load = self._load, 0
                self.delivered += served
            board = min(self._cap - self._load, self._queues[floor])
            if board:
                self._queues[floor] -= board
                self._waiting -= board
                self._queue_obs[self._obs_index[floor]] -= board
                self._load += board

        delivery = self._coeff * served
        waiting = -float(self._load + self._waiting) if (not served or self._always_wait_penalty) else 0.0

        if self._any_arrival[self._t]:
            self._enqueue(self._rows[self._t])
        self._t += 1

        if self._renderer is not None:
            self._renderer.record(self.delivered, self.turned_away, action == OPEN and self._pos % self._ppf == 0)
        done = self._t >= self._duration
        info = self._info({"delivery": delivery, "waiting": waiting})
        return self._obs(), delivery + waiting, done and self._upstream, done and not self._upstream, info

    def _enqueue(self, futures: list[int]) -> None:
        """Last second's arrivals join their queues; who does not fit balks (is turned away)."""
        queues = self._queues
        for k, floor in zip(futures, self._served_floors, strict=True):
            if k:
                wanting = (k + 1) // 2 if self._upstream else k  # upstream: every other arrival is lost
                join = min(wanting, self._max_q - queues[floor])
                queues[floor] += join
                self._waiting += join
                self._queue_obs[self._obs_index[floor]] += join
                self.turned_away += k - join

    def tabular_kernel(self) -> Any:
        """This env's dynamics as compiled functions, for ``gym4real train`` Q-learning and SARSA (needs numba).

        Returns a :class:`gym4real.elevator.kernel.ElevatorKernel`; its ``load(env)`` reads the episode the env
        has just been reset to.
        """
        from gym4real.elevator.kernel import ElevatorKernel

        return ElevatorKernel(self)

    def render(self) -> str | np.ndarray | None:
        """Draw the shaft: ``ansi``, one line per floor, top floor first; ``rgb_array``, an ``H x W x 3`` frame.

        The frame (:mod:`gym4real.elevator.rendering`) shows floors, cabin and load, queues and deliveries so far.
        """
        if self._renderer is not None:
            arrivals = dict(zip(self._served_floors, self._futures(), strict=True))
            return self._renderer.frame(self._t, self._pos, self._load, self._queues, arrivals)
        if self.render_mode != "ansi":
            return None
        e = self.config.elevator
        lines = [f"t={self._t:>5}s  load {self._load}/{self._cap}  delivered {self.delivered}"]
        for level in range(self._top, -1, -1):
            at_floor = level % self._ppf == 0
            cabin = f"[{self._load}]" if level == self._pos else " | "
            if at_floor:
                floor = level // self._ppf
                name = f"F{floor + e.min_floor}"
                queue = "o" * self._queues[floor] + (" (goal)" if floor == self._goal else "")
                lines.append(f"{name:>3} {cabin} {queue}")
            else:
                lines.append(f"    {cabin}")
        return "\n".join(lines) + "\n"
