"""The hindsight planner of MicrogridEnv: a non-causal upper reference that knows the household-year.

At the first decision of an episode the planner reads what no agent can know in advance, the episode's
hourly demand, PV, ask and bid prices and ambient temperatures, and plans the SoC of every hour by dynamic
programming (:mod:`gym4real.microgrid.hindsight_kernel`) against the protocol's objective, trading plus
degradation. Its model of an hour is the twin's terminal-voltage equation at the hour's temperature and
capacity, the market, and the Bolun damage priced linearly: calendar aging at the mean SoC and
temperature of the hour, cyclic aging per unit of SoC moved. The degradation ``g(damage)`` is concave, so
pricing the damage at ``g'`` of the last plan's damage is a minorise-maximise step; the price, the
temperature and capacity trajectories and the cyclic rate are re-estimated from each plan's replay
through a copy of the env (the twin itself: rainflow, heating, capacity fade). The planner keeps the plan
whose replay scores best, the idle battery (``a = 0``) included, and follows it: each hour it asks for
the power that takes the twin's actual SoC to the plan's.

**The local search.** The model is not the twin (rainflow cycles, not SoC moved, age the battery; the SoC
grid rounds), so the kept plan is then finished by a local search through the twin itself
(:func:`gym4real.microgrid.hindsight_kernel.improve`, the batched env's compiled hour, which plays a plan as
the env does): hour by hour along the year, the next ``SEARCH_SPANS`` targets moved by ``SEARCH_CHANGES``
of SoC, each candidate played ``SEARCH_WINDOW`` hours and scored by its trading and the degradation of the
damage it reached; passes repeat (near the last pass's changes) until one gains at most
``SEARCH_TOLERANCE``. The searched targets are kept when the env's own replay scores them higher. On the
test households it gains 0.4 to 2.1 % over the DP's plan, and a further, wider search gains at most 0.095 %
more (docs/headroom.md). ``search=False`` plays the DP's plan.

``planned_objective`` is what the model promised for the DP's kept plan, ``dp_objective`` what the twin gave
that plan, ``replayed_objective`` what the twin gives the plan played (the env's score of the episode, after
the search); ``history`` lists every iteration of the DP.

Given ``weights`` over the objectives of ``gym4real/microgrid-mo-v0`` (trading, degradation:
:mod:`gym4real.microgrid.multi_objective`), the planner plans, replays and keeps plans by the weighted
objective instead, ``w_trading * trading + w_degradation * degradation`` hour by hour: the trading term of
the model and the damage price are scaled by their objective's weight (:func:`weighted_hindsight`, the
factory of the multi-objective upper reference front). Without weights (the default) nothing changes.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.errors import PolicyError
from gym4real.microgrid.battery import KELVIN
from gym4real.microgrid.env import MicrogridEnv
from gym4real.microgrid.multi_objective import SPECS
from gym4real.microgrid.tables import ParameterGrid
from gym4real.wrappers.multi_objective import scalar_env

#: SoC grid step of the dynamic programme. A coarser grid cannot store small surpluses: on households 371
#: and 376, steps 0.005 / 0.0025 / 0.001 / 0.0005 score -150.6 / -143.7 / -139.7 / -138.2 EUR and
#: -448.5 / -443.7 / -440.7 / -439.7 EUR; 0.0005 triples the time.
GRID_STEP = 0.001
#: At most this many plans per episode after the idle battery.
ITERATIONS = 6
#: The plans stop once a replay scores within this fraction of the previous one's objective.
TOLERANCE = 1e-4
#: The local search's changes of the SoC targets.
SEARCH_CHANGES = (0.002, 0.0005, 0.000125)
#: How many consecutive targets a change moves (0: the run of targets equal to the first).
SEARCH_SPANS = (1, 0, 2, 3, 6)
#: Hours the local search plays to compare the changes of an hour's targets.
SEARCH_WINDOW = 24
#: The local search stops after a pass that gains at most this fraction of the objective.
SEARCH_TOLERANCE = 1e-5
#: A twin played by the search agrees with the env's to this fraction of the objective, or is not searched.
SEARCH_AGREEMENT = 1e-9


@dataclass(frozen=True)
class Iteration:
    """One plan of an episode: its model's promise and the twin's score.

    Attributes:
        price: EUR per unit of Bolun damage the plan was made with (0 for the idle battery).
        cyclic_rate: Damage per unit of SoC moved (before the SoC and temperature stress) assumed.
        planned: The model's objective of the plan (trading plus degradation, weighted as the reward).
        replayed: The objective the twin gives the plan.
    """

    price: float
    cyclic_rate: float
    planned: float
    replayed: float


@dataclass(frozen=True)
class _Model:
    """The arrays of :func:`gym4real.microgrid.hindsight_kernel.solve` for one episode (see there)."""

    socs: np.ndarray
    start: int
    margin: np.ndarray
    ask: np.ndarray
    bid: np.ndarray
    dt: float
    charge: np.ndarray
    table: np.ndarray
    temp_index: np.ndarray
    temp_weight: np.ndarray
    cal_rate: np.ndarray
    cal_soc: np.ndarray
    cyc_rate: np.ndarray
    cyc_soc: np.ndarray


@dataclass
class _Replay:
    objective: float
    damage: float
    cyclic: float
    temperature: np.ndarray  # mean battery temperature of each hour (K)
    capacity: np.ndarray  # capacity at the start of each hour (Ah)
    soc: np.ndarray  # SoC at the start of each hour and at the end


class MicrogridHindsight:
    """Baseline ``hindsight``: plan the episode's SoC knowing its data, then track the plan.

    Args:
        env: The microgrid env (wrapped or not), hourly decisions (``decision_interval`` 1).
        grid_step: SoC step of the dynamic programme's grid (anchored at the episode's initial SoC).
        iterations: At most this many plans per episode after the idle battery (fewer once settled).
        weights: Plan the weighted objective of ``gym4real/microgrid-mo-v0`` (one non-negative weight per
            objective: trading, degradation) instead of the protocol's; None: the protocol's.
        search: Finish the kept plan by the local search through the twin (see the module docstring); False
            plays the DP's plan.

    Raises:
        PolicyError: The env is not a MicrogridEnv with ``decision_interval`` 1, or numba is missing.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        grid_step: float = GRID_STEP,
        iterations: int = ITERATIONS,
        weights: Sequence[float] | None = None,
        search: bool = True,
    ) -> None:
        base = scalar_env(env)  # microgrid-mo-v0 included
        if not isinstance(base, MicrogridEnv):
            raise PolicyError(f"the microgrid hindsight planner needs a MicrogridEnv, not {type(base).__name__}")
        if base.config.decision_interval != 1:
            msg = (
                f"the hindsight planner plans hourly decisions, but `decision_interval` is "
                f"{base.config.decision_interval}; make the env with decision_interval=1"
            )
            raise PolicyError(msg)
        if not 0.0 < grid_step <= 0.1:
            raise PolicyError(f"`grid_step` must be in (0, 0.1], not {grid_step}")
        try:
            from gym4real.microgrid import hindsight_kernel
        except ImportError as exc:
            msg = "the hindsight planner's dynamic programme needs numba: pip install 'gym4real-microgrid[fast]'"
            raise PolicyError(msg) from exc
        self._kernel = hindsight_kernel
        self.env = base
        self.weights = None if weights is None else tuple(float(w) for w in weights)
        # each objective's weight (1 and 1: the protocol's objective, trading + degradation; x * 1.0 is x)
        of = {"trading": 1.0, "degradation": 1.0}
        if weights is not None:
            of = {c: w for c, w in SPECS[0].component_weights(weights).items() if c in of}
        self._objective_weights = of
        self._trade_weight = base._weights[0] * base._trading_scale * of["trading"]
        self._degradation_weight = base._weights[1] * of["degradation"]
        self.grid_step = grid_step
        self.iterations = iterations
        self.search = search
        self.targets: np.ndarray | None = None
        self.planned_objective = math.nan
        self.dp_objective = math.nan
        self.replayed_objective = math.nan
        self.search_passes = 0
        self.history: list[Iteration] = []

    @property
    def gap(self) -> float:
        """Planned minus replayed objective of the DP's kept plan (the model's optimism, EUR)."""
        return self.planned_objective - self.dp_objective

    def reset(self, seed: int | None = None) -> None:
        """Forget the plan: the next call plans the new episode."""
        self.targets = None

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The fraction that moves the twin's SoC to the plan's for the coming hour."""
        env = self.env
        if self.targets is None or env._iterations == 0:
            self._plan()
        assert self.targets is not None
        return np.array([_tracking(env, float(self.targets[env._iterations + 1]))], dtype=np.float32)

    # -- planning ------------------------------------------------------------------------------------

    def _plan(self) -> None:
        env = self.env
        data = _episode_data(env)
        idle = self._replay(np.full(data["margin"].size + 1, env.battery.soc))
        rate = self._initial_cyclic_rate()
        model = self._model(data, idle, rate)
        best, best_planned = idle, self._planned(model, np.full(data["margin"].size + 1, model.start))
        self.history = [Iteration(0.0, rate, best_planned, idle.objective)]
        self.targets = np.full(data["margin"].size + 1, env.battery.soc)
        latest = idle
        for _ in range(self.iterations):
            price = self._damage_price(latest.damage)
            targets, planned = self._solve(model, price)
            replay = self._replay(targets)
            self.history.append(Iteration(price, rate, planned, replay.objective))
            if replay.objective > best.objective:
                best, best_planned, self.targets = replay, planned, targets
            settled = abs(replay.objective - latest.objective) <= TOLERANCE * abs(latest.objective)
            latest = replay
            if settled:
                break
            rate = self._calibrated_rate(replay, rate)
            model = self._model(data, replay, rate)
        self.planned_objective, self.dp_objective = best_planned, best.objective
        self.replayed_objective, self.search_passes = best.objective, 0
        if self.search:
            self._search()

    def _search(self) -> None:
        """Finish the kept plan by the local search through the twin (:func:`hindsight_kernel.improve`).

        The twin is the batched env's compiled one (:func:`twin_copies`), which must play the kept plan as the
        env does (to ``SEARCH_AGREEMENT``); otherwise (the upstream fidelity, a fix off, a perturbed env, a
        plan made mid-episode) the plan is kept as it is. The searched targets are kept when the env's own
        replay (:meth:`_replay`) scores them higher.
        """
        assert self.targets is not None
        weights = (self._trade_weight, self._degradation_weight)
        twin = twin_copies(self.env, 3 + 2 * len(SEARCH_CHANGES) * len(SEARCH_SPANS))
        if twin is None:
            return
        state, args, obs_size = twin
        targets = self.targets.copy()
        start = self._kernel.play(targets, state, args, weights, obs_size)
        if abs(start - self.dp_objective) > SEARCH_AGREEMENT * abs(self.dp_objective):
            return
        p = self.env.battery.params
        _, self.search_passes = self._kernel.improve(
            targets, p.soc_min, p.soc_max, np.asarray(SEARCH_CHANGES), np.asarray(SEARCH_SPANS, dtype=np.int64),
            SEARCH_WINDOW, SEARCH_TOLERANCE, state, args, weights, obs_size,
        )  # fmt: skip
        replay = self._replay(targets)
        if replay.objective > self.replayed_objective:
            self.targets, self.replayed_objective = targets, replay.objective

    def _damage_price(self, damage: float) -> float:
        """EUR per unit of damage at ``damage``: ``dSoH/df`` of the SEI model times the SoH cost, weighted."""
        env = self.env
        a = env.battery.params.aging
        slope = a.alpha_sei * a.beta_sei * math.exp(-a.beta_sei * damage) + (1.0 - a.alpha_sei) * math.exp(-damage)
        return self._degradation_weight * env._deg_per_soh * slope

    def _initial_cyclic_rate(self) -> float:
        """Damage per unit of SoC moved in full cycles of depth 0.5 (each moves the SoC by 1) at the reference."""
        a = self.env.battery.params.aging
        depth = 0.5
        return a.cycle_damage(depth, a.soc_ref, 1.0, a.temp_ref) / (2.0 * depth)

    def _stress(self, temperature: np.ndarray, mid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Calendar damage per hour (at SoC stress 1), SoC stress of calendar and of cyclic aging on ``mid``."""
        env = self.env
        a = env.battery.params.aging
        t_stress = np.exp(a.k_temp * (temperature - a.temp_ref) * (a.temp_ref / temperature))
        s_stress = np.exp(a.k_soc * (mid - a.soc_ref))
        ones = np.ones_like(mid)
        cal = a.k_t * env._step_s * (t_stress if "temperature" in a.calendar else 1.0)
        if "time" not in a.calendar:
            cal = cal * 0.0
        cal_soc = s_stress if "soc" in a.calendar else ones
        cyc_soc = s_stress if "soc" in a.cyclic else ones
        return cal * np.ones_like(temperature), cal_soc, cyc_soc

    def _cyclic_temperature(self, temperature: np.ndarray) -> np.ndarray:
        a = self.env.battery.params.aging
        if "temperature" not in a.cyclic:
            return np.ones_like(temperature)
        return np.exp(a.k_temp * (temperature - a.temp_ref) * (a.temp_ref / temperature))

    def _model(self, data: dict[str, np.ndarray], latest: _Replay, rate: float) -> _Model:
        """The DP's model of the episode, with the temperatures and capacities of the latest replay."""
        env = self.env
        p = env.battery.params
        s0 = env.battery.soc
        step = self.grid_step
        below = math.floor((s0 - p.soc_min) / step + 1e-9)
        above = math.floor((p.soc_max - s0) / step + 1e-9)
        socs = s0 + step * np.arange(-below, above + 1)
        temperature = latest.temperature
        dt = env._step_s
        temp_index, temp_weight = _temperature_weights(p.grid, temperature - KELVIN)
        mid = 0.5 * (socs[:, None] + socs[None, :])
        cal_rate, cal_soc, cyc_soc = self._stress(temperature, mid)
        return _Model(
            socs=socs,
            start=below,
            margin=data["margin"],
            ask=data["ask"],
            bid=data["bid"],
            dt=dt,
            charge=latest.capacity * 3600.0 / dt,
            table=_soc_table(p.grid, socs),
            temp_index=temp_index,
            temp_weight=temp_weight,
            cal_rate=cal_rate,
            cal_soc=cal_soc,
            cyc_rate=rate * self._cyclic_temperature(temperature),
            cyc_soc=cyc_soc,
        )

    def _solve(self, model: _Model, price: float) -> tuple[np.ndarray, float]:
        """The DP's optimal SoC path for a damage price, and its model objective."""
        p = self.env.battery.params
        limits = np.array([p.current_min, p.current_max, p.power_min, p.power_max])
        m = model
        path, _ = self._kernel.solve(
            m.socs, m.start, m.margin, m.ask, m.bid, m.dt, m.charge, m.table, m.temp_index, m.temp_weight, limits,
            self._trade_weight, price, m.cal_rate, m.cal_soc, m.cyc_rate, m.cyc_soc,
        )  # fmt: skip
        return m.socs[path], self._planned(model, path)

    def _planned(self, model: _Model, path: np.ndarray) -> float:
        """The model's objective of a path of grid indices: trading plus the degradation of its damage."""
        env, m = self.env, model
        trading, cal, cyc = self._kernel.totals(
            path, m.socs, m.margin, m.ask, m.bid, m.dt, m.charge, m.table, m.temp_index, m.temp_weight,
            m.cal_rate, m.cal_soc, m.cyc_rate, m.cyc_soc,
        )  # fmt: skip
        degradation = self._degradation_weight * env._deg_per_soh * env.battery.params.aging.degradation(cal + cyc)
        return self._trade_weight * trading - degradation

    def _calibrated_rate(self, replay: _Replay, rate: float) -> float:
        """The cyclic damage per unit of stressed SoC moved in the replay (``rate`` if it moved none)."""
        a = self.env.battery.params.aging
        soc = replay.soc
        moved = np.abs(np.diff(soc))
        mid = 0.5 * (soc[1:] + soc[:-1])
        s_stress = np.exp(a.k_soc * (mid - a.soc_ref)) if "soc" in a.cyclic else np.ones_like(mid)
        weight = float(np.sum(moved * s_stress * self._cyclic_temperature(replay.temperature[: mid.size])))
        return replay.cyclic / weight if weight > 1e-9 and replay.cyclic > 0 else rate

    def _replay(self, targets: np.ndarray) -> _Replay:
        """Track ``targets`` through a copy of the env from its present state (the twin as the env runs it)."""
        env = self.env
        sim = copy.copy(env)
        sim.battery = copy.deepcopy(env.battery)
        sim._renderer = None
        n = targets.size - 1
        temperature = np.empty(n)
        capacity = np.empty(n)
        soc = np.empty(n + 1)
        soc[0] = sim.battery.soc
        objective = 0.0
        w_trading, w_degradation = self._objective_weights["trading"], self._objective_weights["degradation"]
        k = 0
        for k in range(n):
            bat = sim.battery
            temp0 = bat.temperature
            capacity[k] = bat.capacity
            action = np.array([_tracking(sim, float(targets[k + 1]))], dtype=np.float32)
            _, _, terminated, truncated, info = sim.step(action)
            comps = info["reward_components"]
            objective += w_trading * comps["trading"] + w_degradation * comps["degradation"]
            temperature[k] = 0.5 * (temp0 + bat.temperature)
            soc[k + 1] = bat.soc
            if terminated or truncated:
                break
        hours = k + 1
        temperature[hours:] = temperature[hours - 1]
        capacity[hours:] = capacity[hours - 1]
        soc[hours + 1 :] = soc[hours]
        bat = sim.battery
        return _Replay(objective, bat.calendar_aging + bat.cyclic_aging, bat.cyclic_aging, temperature, capacity, soc)


def twin_copies(env: MicrogridEnv, copies: int) -> tuple[tuple[np.ndarray, ...], tuple[Any, ...], int] | None:
    """``copies`` compiled twins at the start of ``env``'s episode, for :mod:`gym4real.microgrid.hindsight_kernel`.

    Taken from a :class:`~gym4real.microgrid.vector.MicrogridVectorEnv` of the env's configuration, its
    copies placed at the episode's profile, data row and battery state at rest, with a rainflow stack deep
    enough for a reversal every hour.

    Returns:
        ``(state, args, observation size)``: the twin's arrays (state rows, rainflow stack, size, walk, last
        point, damage, clock) and the compiled step's constants; None when the batched env cannot play this
        env (another fidelity, a fix off, no numba) or the episode has begun.
    """
    from gym4real.microgrid.vector import MicrogridVectorEnv

    if env._iterations != 0:
        return None
    try:
        vec = MicrogridVectorEnv(copies, config=env.config, compiled=True)
    except (ValueError, ImportError):
        return None
    idx = np.arange(copies)
    vec._col[idx] = vec.single.world.labels.index(env._profile)
    vec._row[idx], vec._iterations[idx], vec._limit[idx] = env._row, 0, env._limit
    bat = env.battery
    vec.twin.reset(idx, np.full(copies, bat.soc), np.full(copies, bat.soh), np.full(copies, bat.temperature))
    rainflow = vec.twin.rainflow
    rainflow.reserve(env._limit + 2)
    state = (vec.twin.state, rainflow.stack, rainflow.size, rainflow.walk, rainflow.last, rainflow.damage, vec._clock)
    return state, vec._compiled_args, int(vec._obs_shape[1])


def _tracking(env: MicrogridEnv, target: float, margin: float | None = None) -> float:
    """The fraction of the coming hour's net power that moves the twin's SoC to ``target`` (in [0, 1]).

    ``margin`` is the net power (W) the fraction is of: None for the coming hour's, which the hindsight
    planner knows; the causal controller (:mod:`gym4real.microgrid.mpc`) passes its forecast.
    """
    if margin is None:
        row = env._row
        margin = env._pv[row % env._hour_mod] - env._demand[row % env._n_demand]
    if margin == 0.0:
        return 0.0
    bat = env.battery
    dt = env._step_s
    power = bat.power_for_current((target - bat.soc) * bat.capacity * 3600.0 / dt, dt)
    return min(max(power / margin, 0.0), 1.0)


def _episode_data(env: MicrogridEnv) -> dict[str, np.ndarray]:
    """The coming episode's hourly net power (W), ask and bid (EUR/Wh)."""
    rows = env._row + np.arange(env._limit - env._iterations)
    hour = rows % env._hour_mod
    pv, demand = np.asarray(env._pv)[hour], np.asarray(env._demand)[rows % env._n_demand]
    return {"margin": pv - demand, "ask": np.asarray(env._ask)[hour], "bid": np.asarray(env._bid)[hour]}


def _soc_table(grid: ParameterGrid, socs: np.ndarray) -> np.ndarray:
    """R0, R1, C and OCV at the lookup table's temperatures and the grid's SoCs: ``(4, temperatures, socs)``.

    Interpolated linearly in SoC, clamped at the table's edges (:meth:`ParameterGrid.bilinear`'s first half).
    """
    ss, v = np.asarray(grid.socs), np.asarray(grid.values)
    j = np.clip(np.searchsorted(ss, socs, side="right") - 1, 0, len(ss) - 2)
    ws = np.clip((socs - ss[j]) / (ss[j + 1] - ss[j]), 0.0, 1.0)
    return np.ascontiguousarray(v[:, :, j] * (1.0 - ws) + v[:, :, j + 1] * ws)


def _temperature_weights(grid: ParameterGrid, temp_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each temperature's (°C) lower table temperature and its weight toward the next, clamped at the edges."""
    ts = np.asarray(grid.temps)
    i = np.clip(np.searchsorted(ts, temp_c, side="right") - 1, 0, len(ts) - 2)
    return i.astype(np.int64), np.clip((temp_c - ts[i]) / (ts[i + 1] - ts[i]), 0.0, 1.0)


def hindsight(env: gym.Env[Any, Any]) -> MicrogridHindsight:
    """Baseline factory: the non-causal hindsight planner (knows the episode's demand, PV, prices, weather)."""
    return MicrogridHindsight(env)


def weighted_hindsight(env: gym.Env[Any, Any], weights: Sequence[float], seed: int | None = None) -> MicrogridHindsight:
    """Weight-conditioned factory: the hindsight planner of the weighted objective of ``gym4real/microgrid-mo-v0``.

    ``weights`` (trading, degradation) weigh the raw objectives; ``seed`` is accepted for the
    ``factory(env, weights=w, seed=S)`` convention and unused (the planner is deterministic).
    """
    return MicrogridHindsight(env, weights=weights)
