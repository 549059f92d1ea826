"""The dam's hindsight planner: the best release schedule of a year whose inflows and demand are known.

A non-causal upper reference (:mod:`gym4real.bench.upper_reference`), not a baseline: at the first step
of an episode it reads the year's exogenous series from the environment (inflow, demand, minimum
environmental flow, evaporation and deficit weight of every day, which no agent knows in advance), solves
the year by backward dynamic programming over the lake level, and then plays the plan one day at a time.

**The programme.** The state is the level at the start of a day, on a uniform grid of ``step`` metres
covering every level the year can reach (:meth:`Lake.level_range`); the value between grid levels is
interpolated linearly. The decision is the day's wanted release ``m >= q_min``; the candidates of a day
are the releases that, held all day, bring a grid level exactly to another grid level
(``m = inflow - evaporation - k * A * step / 86400``), the day's minimum flow, the release that meets
the demand exactly (``demand + minimum flow``, the kink of the deficit) and the top of the action box:
the day's objective is piecewise linear in ``m`` with its kinks there, and so is the interpolated value.
Each candidate day is integrated by the environment's own compiled hourly mass balance with its release
bounds (:func:`gym4real.dam.vector_kernel.integrate_copies`), and scored by the protocol's objective
(deficit + overflow + starving, weighted as in :meth:`DamEnv.step`). There is no terminal value: the
objective ends with the year.

**The plan.** Forward from the episode's exact start, each day takes the candidate of highest
``reward + V(next level)`` integrated from the exact storage: a trajectory of the environment itself.
``planned_objectives`` holds the programme's own estimate ``V_0(level)`` (interpolated on the grid) of each
episode, ``dp_objectives`` the objective of this plan.

**The local search.** The grid's interpolation and its quantised releases leave the DP's plan short of the
best (by 0.1 to 1.4 % on the test years). A local search through the env's days then improves it
(:func:`gym4real.dam.hindsight_kernel.improve`): each day's release moved up or down, and release moved
between two days at most ``SEARCH_WINDOW`` days apart, by ``SEARCH_CHANGES`` grid quanta (8 down to 1/64),
each candidate played through the env's compiled hourly mass balance and kept when the year scores more;
passes repeat until one gains at most ``SEARCH_TOLERANCE`` of the objective. The plan played is the
search's, re-integrated by the env's own :meth:`Lake.day` (the function :meth:`DamEnv.step` calls), so
that replaying it through :meth:`DamEnv.step` scores exactly ``forward_objectives``. The planner is still
not exact: a further search (docs/headroom.md: wider transfers, finer changes, random moves) measures the
distance to a better plan. ``search=False`` plays the DP's plan.

**Weights.** Given ``weights`` over the objectives of ``gym4real/dam-mo-v0`` (shortage, flooding:
:mod:`gym4real.dam.multi_objective`), the programme plans the weighted objective instead: each day's deficit
and starving terms weighted by the shortage weight, its overflow term by the flooding weight, which sum over
the year to ``weights`` times the objective vector (:func:`weighted_hindsight`, the factory of the
multi-objective upper reference front); the search improves the weighted objective. ``planned_objectives``,
``dp_objectives`` and ``forward_objectives`` are then of the weighted objective, and the weights are in the
plan's cache key. Without weights (the default) nothing changes: the protocol's objective.

**Grid and cost.** The default 2.5 mm grid (halving 5 mm to 2.5 mm changed 1950's DP plan by 0.57 %). About
5 s of CPU per year for the DP and about 1 s for the search (the 13 test years: 102 s of CPU, measured on a
shared machine); plans are cached. A further search gains at most 0.0076 % on a test year (docs/headroom.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.bench.upper_reference import PlanCache, plan_cache, plan_key
from gym4real.core.errors import ConfigError
from gym4real.dam.env import DamEnv
from gym4real.dam.lake import SECONDS_PER_DAY
from gym4real.dam.multi_objective import SPECS
from gym4real.wrappers.multi_objective import scalar_env

#: The planner's version in its cache keys: bump it when a change alters the plans.
VERSION = "dam-dp-2"
#: The default grid spacing of the lake level (m).
STEP = 0.0025
#: The release changes the local search tries, in grid quanta (the release that moves the level one grid step a day).
SEARCH_CHANGES = tuple(2.0**k for k in range(3, -7, -1))
#: The local search moves release between days at most this many days apart.
SEARCH_WINDOW = 5
#: The local search stops after a pass that gains at most this fraction of the objective.
SEARCH_TOLERANCE = 1e-5


def _kernel() -> Any:
    try:
        from gym4real.dam import hindsight_kernel
    except ImportError:
        raise ImportError(
            "the dam's hindsight planner is compiled with numba: `pip install gym4real-dam[fast]`"
        ) from None
    return hindsight_kernel


class DamHindsight:
    """Plays the dynamic-programming plan of each episode (see the module docstring).

    Args:
        env: The dam environment (``gymnasium.make`` output or raw); its current episode is planned.
        step: Grid spacing of the lake level (m), positive.
        cache: Reuse plans from the user cache (:func:`gym4real.bench.upper_reference.plan_cache`).
        weights: Plan the weighted objective of ``gym4real/dam-mo-v0`` (one non-negative weight per
            objective: shortage, flooding) instead of the protocol's; None: the protocol's.
        search: Improve the DP's plan by the local search through the env's days (see the module docstring);
            False plays the DP's plan.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        step: float = STEP,
        cache: bool = True,
        weights: Sequence[float] | None = None,
        search: bool = True,
    ) -> None:
        if not (math.isfinite(step) and step > 0):
            raise ConfigError(f"hindsight `step` must be a positive grid spacing in m, not {step}")
        unwrapped = scalar_env(env)  # dam-mo-v0 included
        if not isinstance(unwrapped, DamEnv):
            raise ConfigError(f"the dam's hindsight planner needs a DamEnv, not {type(unwrapped).__name__}")
        self.env: DamEnv = unwrapped
        self.step = float(step)
        self.search = bool(search)
        self.weights = None if weights is None else tuple(float(w) for w in weights)
        self._component_weights = None if weights is None else SPECS[0].component_weights(weights)
        self._cache: PlanCache = plan_cache(self.env, VERSION) if cache else PlanCache(None)
        self._plan: list[float] = []
        self.planned_objectives: list[float] = []
        self.forward_objectives: list[float] = []
        self.dp_objectives: list[float] = []

    def reset(self, seed: int | None = None) -> None:
        """Forget the plan: the next call plans the episode the environment has just started."""
        self._plan = []

    def __call__(self, obs: Any) -> np.ndarray:
        """The planned release of the environment's current day."""
        t = self.env.current_step
        if t == 0 or not self._plan:
            self._plan = self.plan()
        return np.array([self._plan[t]], dtype=np.float64)

    # -- planning ----------------------------------------------------------------------------------

    def _constants(self) -> dict[str, Any]:
        env = self.env
        lake = env.lake
        ep = env.episode
        exogenous = np.column_stack([ep.demand, ep.inflow, ep.min_flow, ep.evaporation, ep.deficit_weight])
        compiled = (
            float(lake.surface),
            float(lake.min_level),
            float(lake.max_level),
            float(lake.linear_limit),
            float(lake.linear_slope),
            float(lake.linear_intercept),
            float(lake.alpha),
            float(lake.beta),
            float(lake.C_r),
            float(lake.dt),
        )
        rw = env.config.reward
        costs = (
            float(rw.daily_deficit_coeff),
            float(rw.overflow_coeff),
            float(rw.starving_coeff),
            float(env.config.flood_level),
            float(env.config.starving_level),
        )
        if self._component_weights is not None:  # the weighted objective: each term by its objective's weight
            of = self._component_weights
            costs = (
                costs[0] * of["deficit"],
                costs[1] * of["overflow"],
                costs[2] * of["starving"],
                costs[3],
                costs[4],
            )
        box = (float(env.action_space.low[0]), float(env.action_space.high[0]))
        return {
            "exogenous": exogenous,
            "lake": compiled,
            "substeps": int(lake.substeps),
            "costs": costs,
            "box": box,
            "storage": float(env.storage),
            "step": self.step,
            "evaporates": bool(np.any(exogenous[:, 3] != 0.0)),
        }

    def _grid(self, c: dict[str, Any]) -> tuple[float, int]:
        """The grid's lowest level and its number of levels, covering every level the episode can reach."""
        lake = self.env.lake
        exogenous = c["exogenous"]
        start = lake.storage_to_level(c["storage"])
        drop = float(np.sum(exogenous[:, 3])) * SECONDS_PER_DAY / lake.surface
        low, high = lake.level_range(start, float(exogenous[:, 1].max()), drop)
        points = math.ceil((high - low) / self.step) + 2
        return low, points

    def _candidates(self, c: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
        """Each day's candidate wanted releases (padded with the last), and their counts."""
        exogenous, (a_low, a_high) = c["exogenous"], c["box"]
        quantum = self.env.lake.surface * self.step / SECONDS_PER_DAY
        rows = []
        for demand, inflow, min_flow, evaporation, _ in exogenous:
            floor = min(max(a_low, min_flow), a_high)
            base = inflow - evaporation
            k_low, k_high = math.ceil((base - a_high) / quantum), math.floor((base - floor) / quantum)
            aligned = base - np.arange(k_low, k_high + 1) * quantum
            extra = [floor, a_high, demand + min_flow]
            values = np.concatenate([aligned, [v for v in extra if floor <= v <= a_high]])
            rows.append(np.unique(values))
        width = max(len(r) for r in rows)
        decisions = np.array([np.pad(r, (0, width - len(r)), mode="edge") for r in rows])
        return decisions, np.array([len(r) for r in rows], dtype=np.int64)

    def plan(self) -> list[float]:
        """Plan the environment's current episode from its current state; return the daily wanted releases."""
        c = self._constants()
        # the weights (and a plan without the search) are in the key: such plans never stand for the protocol's
        extra: dict[str, Any] = {} if self.weights is None else {"weights": self.weights}
        if not self.search:
            extra["search"] = False
        key = plan_key(version=VERSION, **extra, **c)
        found = self._cache.get(key)
        if found is None:
            found = self._solve(c)
            self._cache.put(key, found)
        self.planned_objectives.append(float(found["planned"]))
        self.forward_objectives.append(float(found["forward"]))
        self.dp_objectives.append(float(found["dp"]))
        return [float(d) for d in found["decisions"]]

    def _solve(self, c: dict[str, Any]) -> dict[str, Any]:
        kernel = _kernel()
        low, points = self._grid(c)
        decisions, counts = self._candidates(c)
        exogenous, lake, substeps, costs = c["exogenous"], c["lake"], c["substeps"], c["costs"]
        values = kernel.backward(
            low, self.step, points, decisions, counts, exogenous, lake, c["evaporates"], substeps, costs
        )
        env_lake = self.env.lake
        storage = c["storage"]
        planned = float(kernel._value(values[0], low, self.step, env_lake.storage_to_level(storage)))
        chosen = []
        quantum = env_lake.surface * self.step / SECONDS_PER_DAY
        for t in range(exogenous.shape[0]):
            options = self._forward_options(decisions[t, : counts[t]], storage, low, quantum, exogenous[t], c["box"])
            j = kernel.choose(
                storage, t, values, low, self.step, options, exogenous, lake, c["evaporates"], substeps, costs
            )
            chosen.append(float(options[j]))
            storage, _ = env_lake.day(storage, chosen[-1], *exogenous[t, 1:4])
        dp = self._forward(c, chosen)
        refined, forward = self._search(c, chosen, quantum) if self.search else (chosen, dp)
        if forward < dp:  # the search's days and the env's differ in rounding only: never keep a worse plan
            refined, forward = chosen, dp
        return {
            "decisions": refined,
            "planned": planned,
            "forward": forward,
            "dp": dp,
            "grid": [low, self.step, points],
        }

    def _forward(self, c: dict[str, Any], decisions: list[float]) -> float:
        """The objective of the releases ``decisions`` from the episode's start, each day as DamEnv.step plays it."""
        kernel, env_lake, storage, total = _kernel(), self.env.lake, c["storage"], 0.0
        for decision, (demand, inflow, min_flow, evaporation, weight) in zip(decisions, c["exogenous"], strict=True):
            storage, release = env_lake.day(storage, decision, inflow, min_flow, evaporation)
            total += kernel._reward(release, env_lake.storage_to_level(storage), demand, min_flow, weight, c["costs"])
        return float(total)

    def _search(self, c: dict[str, Any], decisions: list[float], quantum: float) -> tuple[list[float], float]:
        """The DP's releases improved by the local search (:func:`~gym4real.dam.hindsight_kernel.improve`).

        The changes tried are ``SEARCH_CHANGES`` grid quanta (the release that moves the level by one grid
        step in a day), transfers up to ``SEARCH_WINDOW`` days apart; passes stop once one gains at most
        ``SEARCH_TOLERANCE`` of the objective. Returns the releases and their objective (:meth:`_forward`).
        """
        exogenous, (a_low, a_high) = c["exogenous"], c["box"]
        low = np.minimum(np.maximum(exogenous[:, 2], a_low), a_high)
        high = np.full(exogenous.shape[0], a_high)
        plan = np.array(decisions, dtype=np.float64)
        _kernel().improve(
            plan, c["storage"], exogenous, c["lake"], c["evaporates"], c["substeps"], c["costs"], low, high,
            quantum * np.asarray(SEARCH_CHANGES), SEARCH_WINDOW, SEARCH_TOLERANCE,
        )  # fmt: skip
        refined = [float(d) for d in plan]
        return refined, self._forward(c, refined)

    def _forward_options(
        self,
        grid_options: np.ndarray,
        storage: float,
        low: float,
        quantum: float,
        day: np.ndarray,
        box: tuple[float, float],
    ) -> np.ndarray:
        """A day's candidates from the exact (off-grid) storage: the grid's, and those landing on grid levels."""
        _, inflow, min_flow, evaporation, _ = day
        floor, top = min(max(box[0], min_flow), box[1]), box[1]
        level = self.env.lake.storage_to_level(storage)
        offset = (level - low) / self.step  # grid levels above the lowest, fractional
        base = inflow - evaporation + (offset - math.floor(offset)) * quantum  # lands exactly on a grid level
        k_low, k_high = math.ceil((base - top) / quantum), math.floor((base - floor) / quantum)
        landing = base - np.arange(k_low, k_high + 1) * quantum
        return np.unique(np.concatenate([grid_options, landing]))


def hindsight(env: gym.Env[Any, Any]) -> DamHindsight:
    """Baseline factory: the non-causal hindsight planner (dynamic programming over a 2.5 mm level grid)."""
    return DamHindsight(env)


def weighted_hindsight(env: gym.Env[Any, Any], weights: Sequence[float], seed: int | None = None) -> DamHindsight:
    """Weight-conditioned factory: the hindsight planner of the weighted objective of ``gym4real/dam-mo-v0``.

    ``weights`` (shortage, flooding) weigh the raw objectives; ``seed`` is accepted for the
    ``factory(env, weights=w, seed=S)`` convention and unused (the planner is deterministic).
    """
    return DamHindsight(env, weights=weights)
