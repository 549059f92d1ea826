"""The model-predictive controller of MicrogridEnv (baseline ``mpc``): the hindsight planner on forecasts.

A causal receding-horizon controller. Every ``cadence`` hours it forecasts the next ``horizon`` hours of
the household's demand and PV and of the market's prices from what the observations have shown so far,
plans the SoC over those hours with the hindsight planner's model and dynamic programme
(:class:`gym4real.microgrid.hindsight.MicrogridHindsight`: the twin's terminal voltage, the market, the
Bolun damage priced linearly), and until the next plan asks each hour for the fraction of the *forecast*
net power that takes the twin's actual SoC to the plan's.

**What it knows** is what an agent is shown, plus the battery it acts through:

* the demand and the PV of every hour already elapsed (the observation's ``demand`` and ``generation``);
* the ask and bid prices up to the coming hour's (the observation's ``ask`` and ``bid`` are the coming
  hour's); later prices are forecast;
* the battery's present state (SoC, temperature, capacity and the damage so far: the twin's state, the
  model's initial condition) and the episode's length.

It never reads the episode's future series: the forecasts are built from the observations alone. The
only reader of the whole episode is the plan cache's key, which finds the actions of an episode already
run (as the planners' caches do, :func:`gym4real.bench.upper_reference.plan_cache`); the actions it
replays were computed causally from the same data.

**Forecasts** (:class:`Profile`): the demand and the PV of an hour are the mean of the same hour of the
last seven days (:data:`DEMAND`, :data:`GENERATION`), the prices after the coming hour those of the same
hour of the day before (:data:`PRICES`); in the episode's first days, the days there are, and before the
hour of the day has been seen, the last value (persistence). Plans look 24 hours ahead (:data:`HORIZON`)
and are made every 24 hours (:data:`CADENCE`). These were chosen on validation episodes (stand-in training
households on the training years, ``scripts/measure_microgrid_mpc.py``), never on the test protocol;
``docs/headroom.md`` gives what each alternative scored and cost there.

**Model over the horizon**: the battery's present temperature and capacity held; the planner's initial
cyclic rate (:meth:`~gym4real.microgrid.hindsight.MicrogridHindsight._initial_cyclic_rate`); the damage
priced at the slope of the degradation (the planner's ``_damage_price``) at the damage projected to the
episode's end: the damage so far plus the remaining hours at its mean rate so far (during the first day,
at the idle battery's calendar rate at the present temperature and SoC). A plan values no energy left at
the end of its horizon.
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.bench.upper_reference import PlanCache, plan_cache, plan_key
from gym4real.core.errors import PolicyError
from gym4real.microgrid.hindsight import GRID_STEP, MicrogridHindsight, _Replay, _tracking

#: Hours in a day and in a week: the periods of the forecasts' profiles.
DAY = 24
WEEK = 7 * DAY


@dataclass(frozen=True)
class Profile:
    """Forecast of an hourly series: the mean of its last ``count`` observed values ``period`` hours apart.

    The values averaged for hour ``q`` are those of hours ``q - period``, ``q - 2 period``, ... (the latest
    ``count`` of them already observed). Where the series has none yet, the profile of the same hour of the
    past days stands in, and where that hour of the day has not been observed either, the last observed
    value (persistence). Period 1 and count 1 is persistence itself.

    Attributes:
        period: Hours between the values averaged (168: the hour of the week, 24: the hour of the day).
        count: At most this many values are averaged.

    Raises:
        PolicyError: A period or count below 1.
    """

    period: int
    count: int

    def __post_init__(self) -> None:
        if self.period < 1 or self.count < 1:
            raise PolicyError(f"a forecast Profile needs period >= 1 and count >= 1 (hours, values), not {self}")

    def __call__(self, history: np.ndarray, hours: np.ndarray) -> np.ndarray:
        """The forecast of ``history``'s hours ``hours`` (indices into the series; observed ones are returned).

        Args:
            history: The values observed so far, one per hour from the series' first (not empty).
            hours: The hours to forecast, as indices from the same first hour.
        """
        last = history.size - 1
        out = np.empty(hours.size)
        known = hours <= last
        out[known] = history[hours[known]]
        todo = ~known
        for period, count in dict.fromkeys(((self.period, self.count), (DAY, self.count), (1, 1))):
            if not todo.any():
                break
            q = hours[todo]
            back = -((last - q) // period)  # the fewest periods back to an observed hour
            lags = q[:, None] - period * (back[:, None] + np.arange(count))
            valid = lags >= 0
            n = valid.sum(axis=1)
            total = np.where(valid, history[np.maximum(lags, 0)], 0.0).sum(axis=1)
            found = np.flatnonzero(todo)[n > 0]
            out[found] = total[n > 0] / n[n > 0]
            todo[found] = False
        return out


#: Hours each plan looks ahead.
HORIZON = 24
#: Hours between plans (the plan is followed, tracked through the twin, in between).
CADENCE = 24
#: Demand forecast: the same hour of the past seven days.
DEMAND = Profile(DAY, 7)
#: PV forecast: the same hour of the past seven days.
GENERATION = Profile(DAY, 7)
#: Forecast of the prices after the coming hour's: the same hour of the past day.
PRICES = Profile(DAY, 1)
#: Name and version of the plans in the cache (a new version starts a new file).
VERSION = "microgrid-mpc-1"


class MicrogridMPC:
    """Baseline ``mpc``: plan the SoC on forecasts every ``cadence`` hours, track the plan in between.

    Args:
        env: The microgrid env (wrapped or not), hourly decisions (``decision_interval`` 1).
        horizon: Hours each plan looks ahead (cut at the episode's end).
        cadence: Hours between plans, in ``[1, horizon]``.
        demand: Forecast of the household's demand.
        generation: Forecast of the PV.
        prices: Forecast of the ask and bid after the coming hour (whose prices the observation shows).
        grid_step: SoC step of the planner's dynamic programme.
        cache: Reuse the actions of an episode already run from the user cache
            (:func:`gym4real.bench.upper_reference.plan_cache`; an episode is stored once run to its last hour).

    Raises:
        PolicyError: The env is not a MicrogridEnv with ``decision_interval`` 1, numba is missing, or a
            horizon or cadence is out of range.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        horizon: int = HORIZON,
        cadence: int = CADENCE,
        demand: Profile = DEMAND,
        generation: Profile = GENERATION,
        prices: Profile = PRICES,
        grid_step: float = GRID_STEP,
        cache: bool = True,
    ) -> None:
        if horizon < 1 or not 1 <= cadence <= horizon:
            msg = "the MPC needs horizon >= 1 and cadence in [1, horizon] (hours)"
            raise PolicyError(f"{msg}, not horizon {horizon}, cadence {cadence}")
        self.planner = MicrogridHindsight(env, grid_step=grid_step)
        self.env = self.planner.env
        self.horizon, self.cadence = int(horizon), int(cadence)
        self.demand, self.generation, self.prices = demand, generation, prices
        names = self.env.feature_names
        self._features = [names.index(f) for f in ("demand", "generation", "ask", "bid")]
        self._cache: PlanCache = plan_cache(env, VERSION) if cache else PlanCache(None)
        self._key = ""
        self._replaying: list[float] | None = None
        self._actions: list[float] = []
        # observed so far: demand and PV from the hour before the episode's first, prices from its first
        self._observed = np.empty((0, 4))
        self._damage0 = 0.0
        self._planned_at = 0
        self._targets = np.empty(0)
        self._margins = np.empty(0)

    def reset(self, seed: int | None = None) -> None:
        """Forget the episode: the next call (the env's first hour) starts the one the env has just reset."""
        self._key = ""

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The fraction of the forecast net power that moves the twin's SoC to the plan's for the coming hour."""
        env = self.env
        k = env._iterations
        if k == 0:
            self._start()
        elif self._key == "":
            raise PolicyError("the MPC forecasts from the episode's first hour on: call it from the env's reset on")
        if self._replaying is not None:
            return np.array([self._replaying[k]], dtype=np.float32)
        self._observed[k] = np.asarray(obs, dtype=np.float64)[self._features]
        if k == 0 or k - self._planned_at >= self.cadence:
            self._plan(k)
        j = k - self._planned_at
        action = _tracking(env, float(self._targets[j + 1]), float(self._margins[j]))
        self._actions.append(float(np.float32(action)))
        if len(self._actions) == env._limit:
            self._cache.put(self._key, self._actions)
        return np.array([action], dtype=np.float32)

    def _start(self) -> None:
        """Begin the episode the env has just reset: replay its cached actions, or observe and plan it."""
        env, bat = self.env, self.env.battery
        self._key = self._episode_key()
        cached = self._cache.get(self._key)
        self._replaying = cached if cached is not None and len(cached) == env._limit else None
        self._actions = []
        self._observed = np.full((env._limit, 4), math.nan)
        self._damage0 = bat.calendar_aging + bat.cyclic_aging

    def _episode_key(self) -> str:
        """A hash of everything the episode's actions depend on (the cache's key; reads the episode's data)."""
        env, bat = self.env, self.env.battery
        return plan_key(
            version=VERSION,
            controller=(self.horizon, self.cadence, *(astuple(p) for p in (self.demand, self.generation, self.prices))),
            grid_step=self.planner.grid_step,
            config=env.config.model_dump(mode="json"),
            battery=repr(bat.params),
            state=bat.snapshot(),
            start=env._row,
            limit=env._limit,
            series=(env._demand, env._pv, env._ask, env._bid, env.world.temp),
        )

    # -- planning ------------------------------------------------------------------------------------

    def _plan(self, k: int) -> None:
        """Forecast the coming ``horizon`` hours from hour ``k``'s observations and plan the SoC over them."""
        env, planner, bat = self.env, self.planner, self.env.battery
        data = self.forecast(k, min(self.horizon, env._limit - k))
        n = data["margin"].size
        held = _Replay(0.0, 0.0, 0.0, np.full(n, bat.temperature), np.full(n, bat.capacity), np.full(n + 1, bat.soc))
        model = planner._model(data, held, planner._initial_cyclic_rate())
        self._targets, _ = planner._solve(model, planner._damage_price(self._projected_damage(k)))
        self._margins = data["margin"]
        self._planned_at = k

    def forecast(self, k: int, n: int) -> dict[str, np.ndarray]:
        """The forecast of episode hours ``k .. k + n - 1`` from the observations up to hour ``k``'s.

        A subclass overrides it to plan on another forecast (``scripts/measure_microgrid_mpc.py`` hands it the
        episode's own series to measure what forecasting costs).

        Returns:
            ``margin`` (PV minus demand, W), ``ask`` and ``bid`` (EUR/Wh) of each hour; the first hour's
            prices are the observed ones.
        """
        hours = np.arange(n)
        seen = self._observed[: k + 1]
        # demand and PV: row i holds the hour before episode hour i (what its observation shows); prices: hour i
        demand = self.demand(seen[:, 0], k + 1 + hours)
        pv = self.generation(seen[:, 1], k + 1 + hours)
        ask, bid = self.prices(seen[:, 2], k + hours), self.prices(seen[:, 3], k + hours)
        return {"margin": pv - demand, "ask": ask, "bid": bid}

    def _projected_damage(self, k: int) -> float:
        """The Bolun damage expected at the episode's end, from its value and mean rate at hour ``k``."""
        env, bat = self.env, self.env.battery
        damage = bat.calendar_aging + bat.cyclic_aging
        if k >= DAY:
            rate = (damage - self._damage0) / k
        else:  # the idle battery's calendar rate at the present temperature and SoC
            calendar, soc_stress, _ = self.planner._stress(np.array([bat.temperature]), np.array([bat.soc]))
            rate = float(calendar[0] * soc_stress[0])
        return damage + rate * (env._limit - k)


def mpc(env: gym.Env[Any, Any]) -> MicrogridMPC:
    """Baseline factory: the causal model-predictive controller (forecasts, the hindsight planner's model)."""
    return MicrogridMPC(env)
