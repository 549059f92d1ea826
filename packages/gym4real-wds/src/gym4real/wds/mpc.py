"""The model-predictive controller of WDSEnv: a causal receding-horizon baseline on forecast demand.

The hindsight planner (:mod:`gym4real.wds.hindsight`) knows the week's demand; this controller sees only
what an agent sees and plans on a forecast of it. At every decision it reads the observation: the tanks'
levels and the demand estimate (a moving average of the multipliers up to the present hour), from which it
recovers the multipliers of every hour so far (:func:`gym4real.wds.demand.multipliers`, exact up to the
observation's float32 rounding). Every ``cadence`` decisions it forecasts the next ``horizon`` hours'
multipliers (:func:`forecast`), runs the hindsight planner's beam search (:func:`~gym4real.wds.hindsight.beam_search`)
over that horizon from the observed tank levels, through copies of the env's EPANET hydraulics fed the
forecast (the nominal network: a perturbed pump curve is a model error the controller does not know), and
plays the first ``cadence`` actions of the best schedule; the horizon is cut at the end of the episode.

**Forecast.** The multiplier of a coming hour is the mean of the episode's past days at that hour of day,
shrunk towards the **network's demand pattern** (the mean daily shape of the training profiles, normalised
to mean 1) scaled to the episode's level so far (the hours so far over the shape's same hours): that scaled
shape counts as one more past day. On the first day, with no past day, the forecast is the scaled shape.
The present hour's multiplier is observed, not forecast.

**Choice and cost**, measured on non-test weeks only (validation profiles 500-519 of ``test1000.csv``,
weights 1 / 1; ``scripts/measure_wds_mpc.py``; the tables are in docs/headroom.md): replanning every hour
over the next 6 hours (``HORIZON`` 6, ``CADENCE`` 1) scored the best mean return, 164.925 against the hindsight
planner's 164.937 (the tank-level rule: 156.90), for about 12.6 s of CPU per week. Longer horizons did not
help (24 h every 2 h: 164.84 for 22 s per week) and rarer replanning cost return (24 h every 4 h: 164.10,
every 6 h: 162.43): a plan far ahead trusts a forecast whose errors fill the tanks past the overflow
threshold. Against persistence (the present hour's multiplier all horizon) the forecast gains 0.07 of mean
return (1.0 on the hardest week); its RMSE 1-5 hours ahead is 0.051 (persistence 0.138, the past days' mean
alone 0.053, the scaled shape alone 0.059) on validation profiles 500-999.

Plans are cached per protocol fingerprint (:func:`gym4real.bench.upper_reference.plan_cache`), one entry
per episode keyed by every input of its actions (the env's configuration and network file, the demand the
env applies, its perturbation, the controller's parameters): a second run replays them. A cached schedule
equals the one the controller computes causally, which only the demand so far decides.
"""

from __future__ import annotations

import hashlib
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.bench.upper_reference import PlanCache, plan_cache, plan_key
from gym4real.core.errors import PolicyError
from gym4real.wds import demand
from gym4real.wds.env import DAY, WDSEnv
from gym4real.wds.hindsight import RESOLUTION, WIDTH, beam_search, step_return

#: Planner name and version of the plan cache: a change of the controller starts a new file.
VERSION = "wds-mpc-1"
#: Hours planned at each replanning (chosen on validation weeks: see the module docstring).
HORIZON = 6
#: Decisions played between two replannings.
CADENCE = 1


def training_shape(profiles: demand.Profiles, day: int) -> np.ndarray:
    """The network's demand pattern: the training profiles' mean multiplier by hour of day, normalised to mean 1."""
    weeks = np.concatenate([profiles.train[name] for names in profiles.buckets.values() for name in names], axis=1)
    shape = weeks.reshape(-1, day, weeks.shape[1]).mean(axis=(0, 2))
    return shape / shape.mean()


def forecast(past: np.ndarray, hours: int, shape: np.ndarray) -> np.ndarray:
    """Multipliers of the ``hours`` hours after ``past`` (the episode's hourly multipliers so far).

    Each hour's forecast is the mean of the past days' multipliers at its hour of day with one more day, the
    daily ``shape`` scaled to the level of ``past`` (its sum over the shape's sum at the same hours).

    Args:
        past: The multipliers from the episode's first hour to the present one (at least one).
        hours: Hours to forecast, at most one day (every forecast hour has the same hour a day before it).
        shape: Mean multiplier per hour of day, normalised to mean 1 (:func:`training_shape`).
    """
    day, n = len(shape), len(past)
    if n < 1 or not 0 <= hours <= day:
        raise PolicyError(f"forecast needs at least one past hour and at most {day} hours ahead, not {n} and {hours}")
    level = float(past.sum() / shape[np.arange(n) % day].sum())
    out = np.empty(hours)
    for i in range(hours):
        hour = (n + i) % day
        same = past[hour::day]  # the past days at this hour of day
        out[i] = (same.sum() + level * shape[hour]) / (len(same) + 1)
    return out


class WDSMPC:
    """Baseline ``mpc``: replan the pumps on forecast demand every ``cadence`` hours (see the module docstring).

    Args:
        env: The WDS env (wrapped or not): fixed decision intervals of one pattern step, pumps switched by the
            agent, a per-episode demand estimate, the DSR of the current multiplier (the corrected mode).
        horizon: Hours planned at each replanning (1 to 24).
        cadence: Decisions played between replannings (1 to ``horizon``).
        width: Search nodes kept per hour (the hindsight planner's).
        resolution: Tank-level cell (m) within which nodes are merged (the hindsight planner's).
        cache: Reuse the schedules of episodes played before (:func:`gym4real.bench.upper_reference.plan_cache`).

    Raises:
        PolicyError: The env is not such a WDSEnv, or a bad argument.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        horizon: int = HORIZON,
        cadence: int = CADENCE,
        width: int = WIDTH,
        resolution: float = RESOLUTION,
        cache: bool = True,
    ) -> None:
        base = env.unwrapped
        if not isinstance(base, WDSEnv):
            raise PolicyError(f"the WDS model-predictive controller needs a WDSEnv, not {type(base).__name__}")
        cfg = base.config
        if not (
            base._fixed
            and base._agent_pumps
            and base._per_episode_estimate
            and not base._first_hour
            and cfg.decision_interval == cfg.pattern_step
            and DAY % cfg.pattern_step == 0
        ):
            msg = (
                "the WDS model-predictive controller plans hourly decisions of the corrected mode: make the env with "
                "fidelity='corrected' (or fixes fixed_interval, per_episode_estimate and dsr_reference='current'), "
                "pump_control='agent' and decision_interval equal to pattern_step, a divisor of a day"
            )
            raise PolicyError(msg)
        day = int(DAY) // cfg.pattern_step
        if not 1 <= horizon <= day or not 1 <= cadence <= horizon or width < 1 or not resolution > 0:
            msg = (
                f"`horizon` must be in [1, {day}], `cadence` in [1, horizon], `width` >= 1 and `resolution` > 0; "
                f"got {horizon}, {cadence}, {width} and {resolution}"
            )
            raise PolicyError(msg)
        self.env = base
        self.horizon, self.cadence, self.width, self.resolution = horizon, cadence, width, float(resolution)
        self.shape = training_shape(base.profiles, day)
        self._cache: PlanCache = plan_cache(base, VERSION) if cache else PlanCache(None)
        self._copies: list[WDSEnv] = []
        self._estimates: list[float] = []
        self._actions: list[int] = []
        self._schedule: tuple[int, ...] = ()
        self._planned_at = 0
        self._key = ""
        self._replay: list[int] | None = None

    def reset(self, seed: int | None = None) -> None:
        """Forget the episode: the next call starts the one the env has just reset."""
        self._estimates, self._actions, self._schedule, self._replay = [], [], (), None

    def __call__(self, obs: np.ndarray) -> int:
        """The action of the present decision (replanning first when ``cadence`` decisions have passed)."""
        env = self.env
        h = env._t // env.config.decision_interval
        if h == 0:
            self._start()
        if self._replay is not None:
            return self._replay[h]
        if h != len(self._actions):
            msg = (
                f"the WDS model-predictive controller is called at decision {h} but acted at {len(self._actions)} "
                "decisions of this episode: call it at every decision from the reset on"
            )
            raise PolicyError(msg)
        self._estimates.append(float(obs[-3]))
        if not self._schedule or h - self._planned_at >= self.cadence:
            self._plan(np.asarray(obs[: len(env.network.tank_ids)], dtype=np.float64), h)
        action = self._schedule[h - self._planned_at]
        self._actions.append(action)
        if h == env._decisions - 1:
            self._cache.put(self._key, self._actions)
        return action

    def close(self) -> None:
        """Release the copies' EPANET projects."""
        for sim in self._copies:
            sim.close()
        self._copies = []

    # -- planning ------------------------------------------------------------------------------------

    def _start(self) -> None:
        """A new episode: look its schedule up in the cache (keyed by every input of the actions)."""
        self.reset()
        env = self.env
        network = hashlib.sha256(env.network.path.read_bytes()).hexdigest()
        config = env.config.model_dump(mode="json", exclude={"data_dir"})
        self._key = plan_key(
            version=VERSION,
            config=config,
            network=network,
            engine=env.engine_label,
            demand=env._pattern,
            scales=env._scales,
            controller=(self.horizon, self.cadence, self.width, self.resolution),
        )
        found = self._cache.get(self._key)
        if found is not None and len(found) == env._decisions:
            self._replay = [int(a) for a in found]

    def _plan(self, levels: np.ndarray, h: int) -> None:
        """Forecast the coming hours and search their schedule from the observed ``levels``."""
        env = self.env
        cfg = env.config
        past = demand.multipliers(np.array(self._estimates), cfg.demand.estimate, cfg.demand.window)
        hours = min(self.horizon, env._decisions - h)
        pattern = np.concatenate([past[-1:], forecast(past, hours - 1, self.shape)])
        pattern = np.clip(pattern, env.profiles.low, env.profiles.high)
        sims = self._pool(pattern)
        self._schedule, _ = beam_search(sims, levels, hours, step_return, self.width, self.resolution)
        self._planned_at = h

    def _pool(self, pattern: np.ndarray) -> list[WDSEnv]:
        """The search's copies of the nominal env, reset to the forecast ``pattern`` (its first hour at t = 0)."""
        n = self.width * 2 ** len(self.env.network.pump_ids)
        while len(self._copies) < n:
            self._copies.append(WDSEnv(self.env.config))
        for sim in self._copies:
            sim.reset(options={"pattern": pattern})
        return self._copies


def mpc(env: gym.Env[Any, Any]) -> WDSMPC:
    """Baseline factory: the causal model-predictive controller (forecast demand, plans 6 hours every hour)."""
    return WDSMPC(env)
