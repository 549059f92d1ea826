"""The dam's causal model-predictive baseline ``mpc``: the hindsight planner's programme on forecasts.

A causal baseline (an agent could run it): it knows what an agent knows and what is public in advance, and
plans with the environment's own model, the hindsight planner's (:mod:`gym4real.dam.hindsight`: the same
candidate releases, the same compiled hourly mass balance and release bounds, the same objective), on
**forecasts** of the exogenous series instead of the year's actual ones.

**What it knows.** At the decision of day ``t``: the current storage (the level the agent observes); the
inflow and demand of the days before ``t``, never of ``t`` or later (a reservoir operator measures the
inflow; the agent recovers each day's demand from its average-demand observation, ``E_t = 0.8 E_{t-1} +
0.2 D_t``); the minimum environmental flow, evaporation rate and deficit weight of every day (tables of the
day of the year, public in advance); the episode's length; the lake's model and the objective.

**Forecast** (:mod:`gym4real.dam.forecast`, fitted on the 52 training years only; on the train split an
episode's own year is left out, so that it is forecast as a held-out year would be): for inflow and demand
alike, each day's mean over the training years (the climatology) plus the last observed day's anomaly from
it times the training years' regression coefficient ``b_k`` of an anomaly ``k`` days later (inflow: 0.76
one day ahead, 0.36 a week, 0.25 two weeks; demand: 0.97, 0.63, 0.44), for up to ``horizon`` days; the
climatology after that, and on the first day (nothing observed yet). On the 13 validation years
(``benchmarks/bench_dam_mpc.py``: IQM of the objective, CPU seconds of the 13 years; docs/headroom.md tables
it) the mean scored -6,775, the median -7,144, the 0.75 quantile -7,824.

**Plan.** At the first decision, the programme of the whole episode on the climatology; its value function
is the **terminal value** of every later plan (after ``horizon`` days the forecast is the climatology, whose
value from each level that programme holds). Every ``cadence`` (7) days, the programme of the next
``horizon`` (15) days from the current storage on the latest forecast, ending on those values. Each day's
release is the candidate of highest (the day's objective + the plan's value of the level it leads to), from
the exact storage, the day's forecast updated with yesterday's inflow and demand (measured while developing,
at a 30-day horizon and a 0.3 m flood margin: IQM -7,680 with this daily re-forecast, -10,381 without it).

**Back-off.** A certainty-equivalent plan rides the thresholds: on the mean forecast it keeps the lake just
under the flood level, and a wetter week than forecast floods it (1,000 per day), a drier end of year starves
it. The planner therefore plans against a flood level ``margins[0]`` = 0.5 m lower and a starving level
``margins[1]`` = 0.05 m higher than the env's (the env scores its own). On the validation years: no back-off
-11,238; flood margin 0.3 m -7,290, 0.4 to 0.8 m -6,384 to -6,775 (a plateau: no difference from 0.5 m the
years resolve); starving margin 0 -9,646, 0.1 m -6,839.

**Horizon, cadence and grid** (validation IQM; CPU seconds of the 13 years on one core):
horizon 7 / **15** / 30 / 60 days: -6,715 / -6,775 / -6,812 / -7,075, 8 / 12 / 21 / 33 s; cadence 1 / **7** / 15
days: -6,672 / -6,775 / -6,266, 60 / 12 / 8 s; grid 5 mm / **1 cm**: -6,927 / -6,775, 34 / 12 s. None differs from
the defaults (bold) by more than the 13 years resolve (95 % paired bootstrap intervals holding 0); the defaults
take two weeks (the inflow anomaly's coefficient is down to 0.25) and a weekly replan. A replan of 15 days costs
about 12 ms of CPU, the climatology's programme of a year about 0.3 s, a day's choice 0.1 ms: about 1 s per year
in all (the 13 test years: about 10 s; their climatology's programme is shared, as they start alike).

**Result.** On the 13 test years (``gym4real bench gym4real/dam-v0 --policies mpc,max,hindsight``), IQM of
the objective -5,749 [-6,606, -4,779], between ``max`` (-18,044) and ``hindsight`` (-1,997).

**Cache.** The decisions of an episode are cached (:func:`gym4real.bench.upper_reference.plan_cache`,
one file per protocol fingerprint) under a hash of everything they depend on: the settings, the forecasts,
the model and the episode's series, which name the episode (a decision never reads them; the episode whose
series differ from day ``t`` on is another entry, run afresh). A second run replays them.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.bench.upper_reference import PlanCache, plan_cache, plan_key
from gym4real.core.datasets import resolve
from gym4real.core.errors import ConfigError
from gym4real.dam.data import DAYS, read_yearly
from gym4real.dam.env import DamEnv
from gym4real.dam.forecast import SeriesForecast, series_forecast, training_matrix
from gym4real.dam.hindsight import DamHindsight, _kernel
from gym4real.dam.lake import SECONDS_PER_DAY

#: The controller's version in its cache keys: bump it when a change alters the decisions.
VERSION = "dam-mpc-1"
#: The default horizon (days) of a replan; beyond it the anomaly of a forecast is forgotten.
HORIZON = 15
#: The default number of days between replans.
CADENCE = 7
#: The default climatology of the forecasts.
STATISTIC: float | str = "mean"
#: The default back-off (m) of the planned flood and starving levels from the env's.
MARGINS = (0.5, 0.05)
#: The default grid spacing of the lake level (m).
STEP = 0.01


@dataclass(frozen=True)
class _Plan:
    """A solved programme: its first day, forecast rows, grid and value function, and each day's candidates."""

    start: int
    rows: np.ndarray
    low: float
    values: np.ndarray
    decisions: np.ndarray
    counts: np.ndarray


class DamMPC:
    """Receding-horizon control on the training years' forecasts (see the module docstring).

    Args:
        env: The dam environment (``gymnasium.make`` output or raw).
        horizon: Days planned at each replan, in [1, 364] (the episode's end bounds it), and how many days
            ahead a forecast carries the last observed anomaly.
        cadence: Days between replans, in [1, ``horizon``].
        statistic: The climatology of the forecasts: ``"mean"`` or a quantile in [0, 1].
        step: Grid spacing of the lake level (m), positive.
        margins: How far (m) below the env's flood level and above its starving level the planner puts them.
        cache: Reuse the decisions of an episode already run from the user cache
            (:func:`gym4real.bench.upper_reference.plan_cache`).
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        horizon: int = HORIZON,
        cadence: int = CADENCE,
        statistic: float | str = STATISTIC,
        step: float = STEP,
        margins: tuple[float, float] = MARGINS,
        cache: bool = True,
    ) -> None:
        if isinstance(horizon, bool) or not isinstance(horizon, int) or not 1 <= horizon < DAYS:
            raise ConfigError(f"mpc `horizon` must be a whole number of days in [1, {DAYS - 1}], not {horizon!r}")
        if isinstance(cadence, bool) or not isinstance(cadence, int) or not 1 <= cadence <= horizon:
            raise ConfigError(
                f"mpc `cadence` must be a whole number of days in [1, `horizon` {horizon}], not {cadence!r}"
            )
        self._planner = DamHindsight(env, step=step, cache=False)  # checks the env and the step
        self.env: DamEnv = self._planner.env
        self.horizon, self.cadence, self.statistic, self.step = horizon, cadence, statistic, float(step)
        self.margins = (float(margins[0]), float(margins[1]))
        cfg = self.env.config
        if not (
            all(math.isfinite(m) and m >= 0 for m in self.margins)
            and cfg.starving_level + self.margins[1] < cfg.flood_level - self.margins[0]
        ):
            raise ConfigError(
                f"mpc `margins` must be two finite back-offs >= 0 (m) that keep the planned starving level below the "
                f"planned flood level ({cfg.starving_level} + starving margin < {cfg.flood_level} - flood margin), "
                f"not {margins!r}"
            )
        series_forecast(np.zeros((1, 365)), statistic, 0)  # a bad statistic fails here, not at the first step
        self._cache: PlanCache = plan_cache(self.env, VERSION) if cache else PlanCache(None)
        self._fits: dict[tuple[Any, ...], tuple[SeriesForecast, SeriesForecast]] = {}
        self._climatological: dict[str, _Plan] = {}
        self._reset_episode()

    def _reset_episode(self) -> None:
        self._key: str | None = None
        self._replay: list[float] | None = None
        self._decisions: list[float] = []
        self._forecasts: tuple[SeriesForecast, SeriesForecast] | None = None
        self._tail: _Plan | None = None
        self._plan: _Plan | None = None
        self._constants: dict[str, Any] = {}

    def reset(self, seed: int | None = None) -> None:
        """Forget the episode: the next call starts the episode the environment has just started."""
        self._reset_episode()

    def __call__(self, obs: Any) -> np.ndarray:
        """The release of the environment's current day."""
        t = self.env.current_step
        if t == 0 or self._forecasts is None:
            self._start()
        if self._replay is not None:
            return np.array([self._replay[t]], dtype=np.float64)
        if self._plan is None or t - self._plan.start >= self.cadence:
            self._plan = self._replan(t)
        decision = self._choose(t, self._plan)
        self._decisions.append(decision)
        if len(self._decisions) == len(self.env.episode.day):
            self._cache.put(str(self._key), {"decisions": self._decisions})
        return np.array([decision], dtype=np.float64)

    # -- forecasts ---------------------------------------------------------------------------------

    def forecasts(self, leave_out: Collection[int] = ()) -> tuple[SeriesForecast, SeriesForecast]:
        """The fitted forecasts of (inflow, demand) on the training years without ``leave_out``."""
        cfg = self.env.config
        drop = cfg.resolved_fixes()["drop_feb29"]
        key = (tuple(sorted(leave_out)), drop)
        found = self._fits.get(key)
        if found is None:
            fitted = []
            for what, high in (("inflow", cfg.max_inflow), ("demand", cfg.max_demand)):
                table = read_yearly(resolve(f"dam/{what}/train", cfg.data_dir), what, 0.0, high)
                fitted.append(series_forecast(training_matrix(table, drop, leave_out), self.statistic, self.horizon))
            found = self._fits[key] = (fitted[0], fitted[1])
        return found

    def _start(self) -> None:
        """Start an episode: its forecasts (without its own years on the train split), or its cached decisions."""
        self._reset_episode()
        env, ep = self.env, self.env.episode
        c = self._planner._constants()  # the model now (a perturbation changes it at a reset)
        self._constants = {k: c[k] for k in ("lake", "substeps", "box", "step")}
        w_deficit, w_overflow, w_starving, flood, starving = c["costs"]
        flood, starving = flood - self.margins[0], starving + self.margins[1]  # the planned thresholds
        self._constants["costs"] = (w_deficit, w_overflow, w_starving, flood, starving)
        own = set(ep.calendar_year) if env.config.split == "train" else set()
        self._forecasts = self.forecasts(own)
        inflow, demand = self._forecasts
        # the key names the episode (its series) to replay decisions taken on it; the decisions never read it
        self._key = plan_key(
            version=VERSION,
            horizon=self.horizon,
            cadence=self.cadence,
            statistic=self.statistic,
            forecasts=[f.climatology for f in (inflow, demand)] + [f.persistence for f in (inflow, demand)],
            episode=np.column_stack([ep.demand, ep.inflow, ep.min_flow, ep.evaporation, ep.deficit_weight]),
            **self._constants,
        )
        found = self._cache.get(self._key)
        if found is not None:
            self._replay = [float(d) for d in found["decisions"]]

    def _rows(self, t: int, days: int, observed: bool = True) -> np.ndarray:
        """The programme's rows of days ``t .. t + days - 1``: forecast demand and inflow, the calendar's tables.

        Only the past is read: the inflow and demand of the day before ``t`` (an operator measures them;
        an agent recovers the demand from its average-demand observation); ``observed=False``: not even
        those (the climatology). The minimum flow, evaporation and deficit weight are tables of the day of
        the year, public in advance.
        """
        ep = self.env.episode
        assert self._forecasts is not None
        inflow, demand = self._forecasts
        calendar = ep.day[t : t + days]
        last = t - 1 if observed and t > 0 else None
        last_day = None if last is None else ep.day[last]
        return np.column_stack(
            [
                demand.predict(calendar, None if last is None else ep.demand[last], last_day),
                inflow.predict(calendar, None if last is None else ep.inflow[last], last_day),
                ep.min_flow[t : t + days],
                ep.evaporation[t : t + days],
                ep.deficit_weight[t : t + days],
            ]
        )

    # -- planning ----------------------------------------------------------------------------------

    def _replan(self, t: int) -> _Plan:
        """Plan ``horizon`` days from day ``t`` onto the values of the climatology's programme to the episode's end.

        The climatology's programme is solved at the episode's first decision (then nothing is observed, so
        it is also that day's plan), and shared by the episodes whose forecasts and start are the same.
        """
        end = len(self.env.episode.day)
        storage = self.env.storage
        if self._tail is None:
            rows = self._rows(t, end - t, observed=False)
            memo = plan_key(start=t, rows=rows, storage=storage, **self._constants)
            found = self._climatological.get(memo)
            if found is None:
                found = self._climatological[memo] = self._solve(t, rows, storage, None)
            self._tail = found
            if t == 0:
                return found
        days = min(self.horizon, end - t)
        return self._solve(t, self._rows(t, days), storage, self._tail if t + days < end else None)

    def _solve(self, start: int, rows: np.ndarray, storage: float, tail: _Plan | None) -> _Plan:
        """The value function of ``rows`` from ``storage``; after them the value of ``tail`` (None: 0)."""
        planner, kernel = self._planner, _kernel()
        c = {**self._constants, "exogenous": rows, "storage": storage, "evaporates": bool(np.any(rows[:, 3] != 0.0))}
        low, points = planner._grid(c)
        decisions, counts = planner._candidates(c)
        terminal = None
        if tail is not None:
            row = tail.values[start + rows.shape[0] - tail.start]
            terminal = np.interp(low + self.step * np.arange(points), tail.low + self.step * np.arange(row.size), row)
        values = kernel.backward(
            low,
            self.step,
            points,
            decisions,
            counts,
            rows,
            c["lake"],
            c["evaporates"],
            c["substeps"],
            c["costs"],
            terminal,
        )
        return _Plan(start, rows, low, values, decisions, counts)

    def _choose(self, t: int, plan: _Plan) -> float:
        """Day ``t``'s release: the best candidate from the exact storage against the plan's values."""
        c = self._constants
        k = t - plan.start
        storage = self.env.storage
        quantum = self.env.lake.surface * self.step / SECONDS_PER_DAY
        rows, grid_options = plan.rows, plan.decisions[k, : plan.counts[k]]
        if k > 0:  # the day's forecast from the latest observations
            rows = rows.copy()
            rows[k] = self._rows(t, 1)[0]
            decisions, counts = self._planner._candidates({"exogenous": rows[k : k + 1], "box": c["box"]})
            grid_options = decisions[0, : counts[0]]
        options = self._planner._forward_options(grid_options, storage, plan.low, quantum, rows[k], c["box"])
        evaporates = bool(np.any(rows[:, 3] != 0.0))
        j = _kernel().choose(
            storage,
            k,
            plan.values,
            plan.low,
            self.step,
            options,
            rows,
            c["lake"],
            evaporates,
            c["substeps"],
            c["costs"],
        )
        return float(options[j])


def mpc(env: gym.Env[Any, Any]) -> DamMPC:
    """Baseline factory: the causal receding-horizon controller on the training years' forecasts."""
    return DamMPC(env)
