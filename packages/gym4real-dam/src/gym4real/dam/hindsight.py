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
``reward + V(next level)`` integrated from the exact storage; the plan is therefore a closed-loop
trajectory of the environment itself, and replaying it through :meth:`DamEnv.step` scores exactly what
the forward pass computed. ``planned_objectives`` holds the programme's own estimate ``V_0(level)``
(interpolated on the grid) of each episode, beside the replayed score the protocol records.

**Weights.** Given ``weights`` over the objectives of ``gym4real/dam-mo-v0`` (shortage, flooding:
:mod:`gym4real.dam.multi_objective`), the programme plans the weighted objective instead: each day's deficit
and starving terms weighted by the shortage weight, its overflow term by the flooding weight, which sum over
the year to ``weights`` times the objective vector (:func:`weighted_hindsight`, the factory of the
multi-objective upper reference front). ``planned_objectives`` and ``forward_objectives`` are then of the
weighted objective, and the weights are in the plan's cache key. Without weights (the default) nothing
changes: the protocol's objective, the same cache keys.

**Grid.** The default 2.5 mm grid: halving it to 1.25 mm changed the IQM of the replayed objective over the
13 test years by 0.16 %, and each year's by at most 0.55 % (2010; docs/headroom.md tables the gaps,
and a slow test checks that year);
halving 5 mm to 2.5 mm changed 1950's by 0.57 %, so 5 mm is not fine enough. About 5 s of CPU
per year (the 13 test years: about 64 s); plans are cached.
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
VERSION = "dam-dp-1"
#: The default grid spacing of the lake level (m).
STEP = 0.0025


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
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        step: float = STEP,
        cache: bool = True,
        weights: Sequence[float] | None = None,
    ) -> None:
        if not (math.isfinite(step) and step > 0):
            raise ConfigError(f"hindsight `step` must be a positive grid spacing in m, not {step}")
        unwrapped = scalar_env(env)  # dam-mo-v0 included
        if not isinstance(unwrapped, DamEnv):
            raise ConfigError(f"the dam's hindsight planner needs a DamEnv, not {type(unwrapped).__name__}")
        self.env: DamEnv = unwrapped
        self.step = float(step)
        self.weights = None if weights is None else tuple(float(w) for w in weights)
        self._component_weights = None if weights is None else SPECS[0].component_weights(weights)
        self._cache: PlanCache = plan_cache(self.env, VERSION) if cache else PlanCache(None)
        self._plan: list[float] = []
        self.planned_objectives: list[float] = []
        self.forward_objectives: list[float] = []

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
        # the weights are in the key, so that plans of a weighted objective never stand for the protocol's
        key = (
            plan_key(version=VERSION, **c)
            if self.weights is None
            else plan_key(version=VERSION, weights=self.weights, **c)
        )
        found = self._cache.get(key)
        if found is None:
            found = self._solve(c)
            self._cache.put(key, found)
        self.planned_objectives.append(float(found["planned"]))
        self.forward_objectives.append(float(found["forward"]))
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
        chosen, forward = [], 0.0
        quantum = env_lake.surface * self.step / SECONDS_PER_DAY
        for t in range(exogenous.shape[0]):
            options = self._forward_options(decisions[t, : counts[t]], storage, low, quantum, exogenous[t], c["box"])
            j = kernel.choose(
                storage, t, values, low, self.step, options, exogenous, lake, c["evaporates"], substeps, costs
            )
            decision = float(options[j])
            demand, inflow, min_flow, evaporation, weight = exogenous[t]
            storage, release = env_lake.day(storage, decision, inflow, min_flow, evaporation)
            forward += kernel._reward(release, env_lake.storage_to_level(storage), demand, min_flow, weight, costs)
            chosen.append(decision)
        return {"decisions": chosen, "planned": planned, "forward": forward, "grid": [low, self.step, points]}

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
