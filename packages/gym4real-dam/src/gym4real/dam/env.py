"""DamEnv: daily release decisions for Lake Como, integrated with hourly mass-balance sub-steps."""

from __future__ import annotations

import copy
import math
import random
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from gym4real.core.actions import box_value
from gym4real.core.datasets import resolve
from gym4real.core.errors import ConfigError, DataFileError
from gym4real.core.perturbation import check_scales
from gym4real.dam.config import DamConfig
from gym4real.dam.data import calendar_days, read_daily_column, read_yearly
from gym4real.dam.lake import SECONDS_PER_DAY, Lake, deficit_weight

if TYPE_CHECKING:
    from gym4real.dam.rendering import DamRenderer

COMPONENTS = ("deficit", "overflow", "starving", "wasted_water", "clipping")
PERTURBABLE = ("lake_surface", "inflow")
_RESET_OPTIONS = ("year", "rewind_profiles", "init_level")
#: What an action means, for the error of an action outside the action space.
RELEASE = "one release decision in m3/s"
_F32 = np.float32


@dataclass(frozen=True)
class Episode:
    """The exogenous series of one episode, per step ``t`` (precomputed once per starting year).

    ``day[t]`` is the 0-based day of year simulated at step ``t`` and ``calendar_year[t]`` the year whose
    demand, inflow and recorded level it reads (the next year after 31 December where the split has it);
    ``recorded_level[t]`` the recorded level at the start of that day (None without recorded levels).
    """

    year: int
    day: tuple[int, ...]
    calendar_year: tuple[int, ...]
    demand: tuple[float, ...]
    inflow: tuple[float, ...]
    min_flow: tuple[float, ...]
    evaporation: tuple[float, ...]
    deficit_weight: tuple[float, ...]
    recorded_level: tuple[float, ...] | None


class DamEnv(gym.Env[np.ndarray, np.ndarray]):
    """Release control of Lake Como (Gym4ReaL ``DamEnv``).

    ## Description
    Each step is one day of a historical year (Lake Como, 1946-2010): the agent sets the day's target
    release; the lake is integrated in ``integration`` (24) sub-steps in which the release is the target
    clipped into ``[q_min(l, t), q_max(l)]`` (paper appendix: 0 below l_min = -0.5 m; the day's minimum
    environmental flow, then the rating curve ``C_r (l - alpha)^beta`` above l_max = 1.25 m; the upper
    bound linear ``k l + c`` up to l_lim = -0.4 m, then the rating curve) and the storage follows the mass
    balance ``dS = dt (inflow - release - evaporation)`` with the constant surface 145.9 km2.
    The lake surface and the inflow can be scaled through :meth:`perturb` (see Arguments).

    ## Action Space
    ``Box(0.0, 491.61, (1,), float32)``: the target release in m3/s (bounds from ``action``). An action
    outside the box is clipped into it (``invalid_action="clip"``, the reference) or rejected with a
    ValueError (``"raise"``); a NaN or an infinity, or an action with other than one element, always raises
    :class:`~gym4real.core.errors.ActionError` (a ValueError).

    ## Observation Space
    ``Box(float32)`` with the requested ``observations`` in this order:

    | feature | bounds | meaning |
    |---|---|---|
    | level | ``level_bounds`` (-1, 6) m | lake level after the day |
    | sin, cos of day of year | [-1, 1] | angle ``2 pi d / T`` of the next decision's day (0-based d) |
    | exponential average demand | [0, ``max_demand``] | ``E <- 0.8 E + 0.2 D_t``, including today's demand |

    The level bounds are checked at construction against every level reachable in an episode (from the
    initial level, the largest accepted inflow, and for the low end the largest fall that evaporation
    exceeding the data's inflows can cause below l_min), so observations never leave the box.

    ## Rewards
    The sum of five weighted non-positive terms, in ``info["reward_components"]`` (unweighted values in
    ``info["unweighted_components"]``): ``deficit`` = -max(D - max(q - MEF, 0), 0) w(d) with the seasonal
    weight w in [1, 2]; ``overflow`` = -1 if the level ends above ``flood_level``; ``starving`` = -1 if it
    ends below ``starving_level``; ``wasted_water`` = -max(q - D, 0); ``clipping`` = -(a - q)^2, with q the
    day's mean release and a the (clipped) decision. The paper's objective is deficit + overflow +
    starving. ``info["cost"]`` is 1.0 on a day ending in overflow or starving, else 0.0.

    ## Starting State
    Level ``lake.init_level`` (0.35 m), average demand 0. The year: drawn at random from the split
    (``year_selection="random"``, the ``train`` preset) or the split's years in file order
    (``"cycle"``, the ``test`` preset: 1950, 1970, ..., 1974). ``reset(options=...)`` takes ``year``
    (that year), ``rewind_profiles`` (restart the cycle) and ``init_level`` (start level, m).

    An episode that does not start on 1 January (``doy`` > 1) or lasts more than a year runs past
    31 December into the next calendar year: demand, inflow and recorded levels then come from the next
    year of the split when the split holds it (consecutive years are often in different splits, and
    reading the other split would leak held-out years into training), else from the same year again,
    from 1 January. ``info["calendar_year"]`` says which.

    ## Episode End
    Truncation after ``sim_horizon`` (365) days; no termination (floods and starvation are penalised).
    The last step's ``info`` holds ``recorded_level_rmse``, the RMS gap (m) between the simulated and the
    recorded start-of-day levels of the episode's days.

    ## Arguments
    ``gymnasium.make("gym4real/dam-v0", config=None, preset=None, render_mode=None, **overrides)``:
    presets ``default``/``train`` (52 training years, random), ``test`` (13 test years, in order),
    ``validation`` (13 training years, in order); overrides are :class:`DamConfig` fields.
    ``render_mode``: ``"ansi"`` (a line of text) or ``"rgb_array"`` (480 x 320 frames: the level against
    the thresholds, today's inflow, release and demand, and the episode's traces).
    Perturbable parameters (``perturbable``, set with :meth:`perturb`, e.g. by
    ``gym4real.wrappers.ExogenousPerturbation``): ``lake_surface`` (the surface of the mass balance, and
    with it the evaporated volume) and ``inflow`` (every day's inflow), in both fidelity modes.

    ## Corrected mode and ``fidelity="upstream"``
    The default mode fixes the reference's defects; ``fidelity="upstream"`` reproduces the reference
    exactly (same floating-point results). Fixes that change numbers can be switched one by one in
    ``fixes`` (null follows ``fidelity``):

    1. ``current_level_observation``: corrected, the observation holds the current level. The reference
       reads the level history at the day-of-year index, so its final observation shows the initial
       level (and ``doy`` other than 1 fails; it is rejected in that mode).
    2. ``inflow_by_day_of_year``: corrected, inflow, demand, minimum flow and evaporation are all indexed
       by the simulated day of year (the reference indexes inflow by step; the same only for ``doy=1``).
    3. ``np_random_years``: corrected, years are drawn from ``np_random`` seeded by ``reset(seed=)``, in
       cycle mode a seeded reset selects year number ``seed % n_years``, and the first unseeded reset
       takes the first year. The reference draws from a ``random.Random(seed)`` (a fresh one for a
       seeded reset), ignores the seed in cycle mode, and already selects a year at construction: one
       draw of its stream is spent, and in cycle mode the first reset without ``rewind_profiles``
       skips the first year.
    4. ``drop_feb29``: corrected, 29 February of the 14 + 2 leap years is dropped so that every day index
       is the same calendar day; the reference keeps the first 365 values (drops 31 December).

    Also corrected in both modes (no change of numbers): float32 bounds (finite, see above; the
    reference's are infinite float64); ``info["action"]`` is the clipped action (the requested one, as a float, is in
    ``info["raw_action"]``; upstream ``info["action"]`` is raw and the reference's ``pure_reward`` and
    ``weighted_reward`` dicts are added); ``evaporation`` reads a real evaporation-rate file (the
    reference crashes) and is rejected without one; data files are resolved and validated; no pygame.
    Documented, kept: observation days are 0-based while the reward's are 1-based; the average demand
    starts at 0 and includes the current day's demand; ``terminated`` is never true.

    ## Version History
    * v0: Gym4ReaL v1.0 dynamics, corrected by default.
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 8}
    reward_component_names = COMPONENTS
    perturbable: tuple[str, ...] = PERTURBABLE
    action_space: spaces.Box
    observation_space: spaces.Box

    def __init__(
        self,
        config: DamConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        self.config = cfg = DamConfig.build(config, preset, **overrides)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, not {render_mode!r}")
        self.render_mode = render_mode
        self._renderer: DamRenderer | None = None
        if render_mode == "rgb_array":
            from gym4real.dam.rendering import DamRenderer

            self._renderer = DamRenderer(cfg.sim_horizon, cfg.flood_level, cfg.starving_level)
        self._upstream = cfg.fidelity == "upstream"
        self._fixes = fixes = cfg.resolved_fixes()
        lk = cfg.lake
        self._scales = dict.fromkeys(PERTURBABLE, 1.0)  # of the current model
        self._pending = dict(self._scales)  # from the next reset
        self.lake = self._make_lake(lk.surface)
        self._load_data()

        # spaces (float32 bounds; the clipping uses the float32 values, as the reference does)
        self.action_space = spaces.Box(
            np.float32(cfg.action.low), np.float32(cfg.action.high), shape=(1,), dtype=np.float32
        )
        self._a_low = float(self.action_space.low[0])
        self._a_high = float(self.action_space.high[0])
        lows: list[float] = []
        highs: list[float] = []
        self._i_level: int | None = None
        self._i_ead: int | None = None
        if "level" in cfg.observations:
            self._i_level = len(lows)
            lows.append(cfg.level_bounds[0])
            highs.append(cfg.level_bounds[1])
        self._i_day = len(lows) if "day_of_year" in cfg.observations else None
        if self._i_day is not None:
            lows += [-1.0, -1.0]
            highs += [1.0, 1.0]
        if "exponential_average_demand" in cfg.observations:
            self._i_ead = len(lows)
            lows.append(0.0)
            highs.append(cfg.max_demand)
        self.observation_space = spaces.Box(
            np.array(lows, dtype=np.float32), np.array(highs, dtype=np.float32), dtype=np.float32
        )
        self._check_level_bounds(lk.init_level)

        # day-of-year features of the observations at t' = 0..H (0-based day of the next decision)
        H, T = cfg.sim_horizon, cfg.period
        self._obs_day = [(cfg.doy - 1 + t) % T for t in range(H + 1)]
        self._sin = [math.sin(2 * math.pi * d / T) for d in self._obs_day]
        self._cos = [math.cos(2 * math.pi * d / T) for d in self._obs_day]
        self._full_obs = self._i_level == 0 and self._i_day == 1 and self._i_ead == 3
        # hot-loop constants as plain attributes
        self._H = H
        self._ead_c = cfg.exponential_average_coeff
        self._ead_1c = 1 - cfg.exponential_average_coeff
        rw = cfg.reward
        self._w_deficit, self._w_overflow, self._w_starving = (
            rw.daily_deficit_coeff,
            rw.overflow_coeff,
            rw.starving_coeff,
        )
        self._w_wasted, self._w_clip = rw.wasted_water_coeff, rw.clip_action_coeff
        self._flood, self._starving = cfg.flood_level, cfg.starving_level
        self._area, self._lmin = lk.surface, lk.min_level
        self._day = self.lake.day
        self._current_level_obs = fixes["current_level_observation"]
        self._py_rng = random.Random(cfg.seed)  # the reference's year stream (upstream seeding)
        self._cycle: int | None = None
        self._episodes: dict[int, Episode] = {}
        self._episode_rows: dict[int, list[tuple[float, float, float, float, float, int]]] = {}
        if fixes["np_random_years"]:
            self._start(self._years[0], lk.init_level)
        else:  # the reference selects a year at construction (one draw, or the first year of the cycle)
            self._start(self._select_year(None, {}), lk.init_level)

    # -- data --------------------------------------------------------------------------------------

    def _load_data(self) -> None:
        cfg = self.config
        paths = {w: resolve(f"dam/{w}/{cfg.split}", cfg.data_dir) for w in ("demand", "inflow")}
        self._demand = read_yearly(paths["demand"], "demand", 0.0, cfg.max_demand)
        self._inflow = read_yearly(paths["inflow"], "inflow", 0.0, cfg.max_inflow)
        self._calendars: dict[int, tuple[tuple[int, ...], tuple[int, ...]]] = {}  # of `_calendar`, by year
        for year in self._demand.years:
            n_in = len(self._inflow.values.get(year, ()))
            if n_in != len(self._demand.values[year]):
                msg = (
                    f"demand file `{paths['demand']}` and inflow file `{paths['inflow']}` disagree on year "
                    f"{year}: {len(self._demand.values[year])} vs {n_in} values; expected the same years and days"
                )
                raise DataFileError(msg)
        if set(self._inflow.years) != set(self._demand.years):
            extra = sorted(set(self._inflow.years) ^ set(self._demand.years))
            msg = f"demand file `{paths['demand']}` and inflow file `{paths['inflow']}` differ in years {extra}"
            raise DataFileError(msg)
        self._mef = read_daily_column(resolve("dam/mef", cfg.data_dir), "minimum environmental flow", "MEF")
        self._evaporation_rates: tuple[float, ...] | None = None
        if cfg.lake.evaporation:
            assert cfg.lake.evaporation_rates is not None  # the config validator ensures it
            self._evaporation_rates = read_daily_column(Path(cfg.lake.evaporation_rates), "evaporation rate")
        self._evaporation = self._evaporation_flows(cfg.lake.surface)
        self._levels_table = None
        if cfg.recorded_level:
            self._levels_table = read_yearly(resolve(f"dam/level/{cfg.split}", cfg.data_dir), "level")
        years = cfg.years if cfg.years is not None else list(self._demand.years)
        missing = [y for y in years if y not in self._demand.values]
        if missing:
            msg = f"`years` {missing} are not in the {cfg.split} split; its years are {list(self._demand.years)}"
            raise ConfigError(msg)
        self._years = tuple(years)

    def _make_lake(self, surface: float) -> Lake:
        cfg, lk = self.config, self.config.lake
        return Lake(
            surface,
            lk.min_level,
            lk.max_level,
            lk.alpha,
            lk.beta,
            lk.C_r,
            lk.linear_slope,
            lk.linear_intercept,
            lk.linear_limit,
            cfg.integration,
        )

    def _evaporation_flows(self, area: float) -> list[float]:
        """Daily evaporation (m3/s) of a lake of this surface (m2): the rate (mm/day) times the surface."""
        if self._evaporation_rates is None:
            return [0.0] * 365
        return [rate / 1000 * area / SECONDS_PER_DAY for rate in self._evaporation_rates]

    def _episode(self, year: int) -> Episode:
        """The precomputed series of a year (cached)."""
        ep = self._episodes.get(year)
        if ep is not None:
            return ep
        cfg, drop = self.config, self._fixes["drop_feb29"]
        days, years = self._calendar(year)
        demand = {y: calendar_days(self._demand, y, drop) for y in set(years)}
        recorded = None
        if self._levels_table is not None and year in self._levels_table.values:
            levels = {y: calendar_days(self._levels_table, y, drop) for y in set(years)}
            recorded = tuple(levels[y][d] for y, d in zip(years, days, strict=True))
        ep = Episode(
            year=year,
            day=days,
            calendar_year=years,
            demand=tuple(demand[y][d] for y, d in zip(years, days, strict=True)),
            inflow=self._inflows(year, self._scales["inflow"]),
            min_flow=tuple(self._mef[d] for d in days),
            evaporation=tuple(self._evaporation[d] for d in days),
            deficit_weight=tuple(deficit_weight(d, cfg.smooth_daily_deficit_coeff) for d in days),
            recorded_level=recorded,
        )
        self._episodes[year] = ep
        # per step: (demand, inflow, min flow, evaporation, deficit weight, 1-based day), for `step`
        self._episode_rows[year] = list(
            zip(
                ep.demand, ep.inflow, ep.min_flow, ep.evaporation, ep.deficit_weight, [d + 1 for d in days], strict=True
            )
        )
        return ep

    def _calendar(self, year: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
        """Per step of an episode starting in ``year``: the 0-based day of year and the calendar year (cached)."""
        found = self._calendars.get(year)
        if found is None:
            cfg = self.config
            offsets = range(cfg.doy - 1, cfg.doy - 1 + cfg.sim_horizon)
            years = []
            for o in offsets:
                later = year + o // cfg.period
                years.append(later if later in self._demand.values and later in self._inflow.values else year)
            found = self._calendars[year] = (tuple(o % cfg.period for o in offsets), tuple(years))
        return found

    def _inflows(self, year: int, scale: float) -> tuple[float, ...]:
        """The inflow of each step of an episode starting in ``year``, scaled by ``scale``."""
        drop = self._fixes["drop_feb29"]
        days, years = self._calendar(year)
        series = {y: calendar_days(self._inflow, y, drop) for y in set(years)}
        if scale != 1.0:
            series = {y: [q * scale for q in v] for y, v in series.items()}
        if not self._fixes["inflow_by_day_of_year"]:  # the reference: the year's values by step
            return tuple(series[year][: len(days)])
        return tuple(series[y][d] for y, d in zip(years, days, strict=True))

    def _evaporation_drop(self, area: float, inflow_scale: float) -> float:
        """The largest fall (m) below l_min, where nothing is released, in an episode of this env's years.

        It is the largest sum of (evaporation - inflow) over consecutive days of an episode, over the surface.
        """
        if self._evaporation_rates is None:
            return 0.0
        evaporation = self._evaporation_flows(area)
        worst = 0.0
        for year in self._years:
            days, _ = self._calendar(year)
            run = 0.0
            for d, q in zip(days, self._inflows(year, inflow_scale), strict=True):
                run = max(0.0, run + evaporation[d] - q)
                worst = max(worst, run)
        return worst * SECONDS_PER_DAY / area

    def _check_level_bounds(
        self, start: float, lake: Lake | None = None, scales: Mapping[str, float] | None = None
    ) -> None:
        """Check the levels reachable from ``start`` against ``level_bounds`` (default: the current model)."""
        cfg = self.config
        lake = lake or self.lake
        scales = scales or self._scales
        drop = self._evaporation_drop(lake.surface, scales["inflow"])
        try:
            low, high = lake.level_range(start, cfg.max_inflow * scales["inflow"], drop)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
        if low < cfg.level_bounds[0] or high > cfg.level_bounds[1]:
            msg = (
                f"levels in [{low:.3f}, {high:.3f}] m are reachable from {start} m, outside `level_bounds` "
                f"{list(cfg.level_bounds)}; widen `level_bounds` (or lower `max_inflow`)"
            )
            raise ConfigError(msg)

    # -- perturbation ------------------------------------------------------------------------------

    def perturb(self, scales: Mapping[str, float]) -> None:
        """Scale domain parameters from the next :meth:`reset` on, until the next call.

        The scales multiply the nominal values of the configuration (they never compound: each call
        replaces the previous scales, and a name left out is nominal, so ``perturb({})`` or all 1.0
        restores the nominal model exactly).

        Args:
            scales: Multipliers by name: ``lake_surface`` scales the surface ``lake.surface`` of the mass
                balance ``dh = dt (inflow - release - evaporation) / A`` (the evaporated volume, a rate
                in mm/day times the surface, scales with it); ``inflow`` scales every day's inflow.

        Raises:
            ValueError: A name other than those of ``perturbable``; a scale that is not a finite positive
                number; scales under which the lake could leave ``level_bounds`` in an episode.
        """
        new = check_scales(scales, PERTURBABLE)
        lake = self._make_lake(self.config.lake.surface * new["lake_surface"])
        try:
            self._check_level_bounds(self.config.lake.init_level, lake, new)
        except ConfigError as exc:
            raise ValueError(f"perturbation {new}: {exc}") from None
        self._pending = new

    def _apply_perturbation(self) -> None:
        """Make the pending scales the current model (the episode series are recomputed lazily)."""
        if self._pending == self._scales:
            return
        self._scales = self._pending
        self.lake = self._make_lake(self.config.lake.surface * self._scales["lake_surface"])
        self._day = self.lake.day
        self._area = self.lake.surface
        self._evaporation = self._evaporation_flows(self._area)
        self._episodes.clear()
        self._episode_rows.clear()

    @property
    def scales(self) -> dict[str, float]:
        """The perturbation scales of the current model (1.0: nominal)."""
        return dict(self._scales)

    # -- state -------------------------------------------------------------------------------------

    def _start(self, year: int, level: float) -> None:
        self._ep = self._episode(year)
        self._rows = self._episode_rows[year]
        self._year = year
        self._t = 0
        self._ead = 0.0
        self._level = level
        self._storage = self.lake.level_to_storage(level)
        self._levels = [level]
        if self._renderer is not None:
            self._renderer.start()

    @property
    def year(self) -> int:
        """The year of the current episode."""
        return self._ep.year

    @property
    def episode(self) -> Episode:
        """The exogenous series of the current episode."""
        return self._ep

    @property
    def current_step(self) -> int:
        """Steps taken in the current episode."""
        return self._t

    @property
    def level(self) -> float:
        """The current lake level (m)."""
        return self._level

    @property
    def storage(self) -> float:
        """The current storage (m3)."""
        return self._storage

    @property
    def exponential_average_demand(self) -> float:
        """The exponential average of the demand, including the last simulated day's."""
        return self._ead

    @property
    def years(self) -> tuple[int, ...]:
        """The years this environment draws episodes from, in order."""
        return self._years

    def _observation(self) -> np.ndarray:
        t = self._t
        level = self._level if self._current_level_obs else self._levels[self._obs_day[t]]
        if self._full_obs:
            return np.array((level, self._sin[t], self._cos[t], self._ead), _F32)
        values = []
        if self._i_level is not None:
            values.append(level)
        if self._i_day is not None:
            values += [self._sin[t], self._cos[t]]
        if self._i_ead is not None:
            values.append(self._ead)
        return np.array(values, _F32)

    # -- gymnasium API -----------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode on a year (see Starting State) at the initial level."""
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = sorted(set(options) - set(_RESET_OPTIONS))
        if unknown:
            raise ValueError(f"unknown reset options {unknown}; expected some of {list(_RESET_OPTIONS)}")
        self._apply_perturbation()
        year = self._select_year(seed, options)
        level = self.config.lake.init_level
        if options.get("init_level") is not None:
            level = float(options["init_level"])
            if not math.isfinite(level):
                raise ValueError(f"reset option `init_level` must be a finite level in m, not {level}")
            try:
                self._check_level_bounds(level)
            except ConfigError as exc:
                raise ValueError(f"reset option `init_level`: {exc}") from None
        self._start(year, level)
        info = {
            "year": year,
            "level": level,
            "storage": self._storage,
            "exponential_average_demand": 0.0,
            "reward_components": dict.fromkeys(COMPONENTS, 0.0),
            "cost": 0.0,
        }
        return self._observation(), info

    def _select_year(self, seed: int | None, options: dict[str, Any]) -> int:
        years, n = self._years, len(self._years)
        if options.get("year") is not None:
            year = options["year"]
            if year not in years:
                raise ValueError(f"reset option `year` = {year!r} is not one of this env's years {list(years)}")
            self._cycle = years.index(year)
            return int(year)
        seeded = self._fixes["np_random_years"]
        if self.config.year_selection == "random":
            if seeded:
                return years[int(self.np_random.integers(n))]
            rng = self._py_rng if seed is None else random.Random(seed)
            return rng.choice(list(years))
        if options.get("rewind_profiles"):
            self._cycle = None
        if seeded and seed is not None:
            self._cycle = seed % n
        else:
            self._cycle = 0 if self._cycle is None else (self._cycle + 1) % n
        return years[self._cycle]

    def _decision(self, action: Any) -> float:
        """The action as a float inside the box (clipped, or ActionError, as configured)."""
        keep = self.config.invalid_action == "clip"  # the env clips, after recording the requested release
        fix = 'clip it, or set `invalid_action="clip"`'
        a = box_value(action, self.action_space, RELEASE, outside="keep" if keep else "raise", fix=fix)
        self._raw_action = a
        return self._a_low if a < self._a_low else self._a_high if a > self._a_high else a

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Release water for one day; return the observation after the day."""
        a = self._decision(action)
        t = self._t
        if t >= self._H:
            raise RuntimeError("the episode is over (truncated); call `reset()` before `step()`")
        demand, inflow, min_flow, evaporation, weight, day = self._rows[t]
        ead = self._ead = self._ead_c * self._ead + self._ead_1c * demand
        storage, release = self._day(self._storage, a, inflow, min_flow, evaporation)
        level = storage / self._area + self._lmin
        self._storage = storage
        self._level = level
        self._levels.append(level)
        if self._renderer is not None:
            self._renderer.record(release)

        # reward: the reference's expressions, in its order of operations
        overflow = -1.0 if level > self._flood else 0.0
        starving = -1.0 if level < self._starving else 0.0
        supplied = release - min_flow
        if supplied < 0.0:
            supplied = 0.0
        shortfall = demand - supplied
        deficit = (shortfall if shortfall > 0.0 else 0.0) * weight
        surplus = release - demand
        wasted = -surplus if surplus > 0.0 else -0.0
        clipping = -((a - release) ** 2)
        w_deficit = -deficit * self._w_deficit
        w_overflow = overflow * self._w_overflow
        w_starving = starving * self._w_starving
        w_wasted = wasted * self._w_wasted
        w_clipping = clipping * self._w_clip
        reward = 0.0 + w_overflow + w_starving + w_deficit + w_wasted + w_clipping

        self._t = t = t + 1
        truncated = t >= self._H
        info = {
            "reward_components": {
                "deficit": w_deficit,
                "overflow": w_overflow,
                "starving": w_starving,
                "wasted_water": w_wasted,
                "clipping": w_clipping,
            },
            "unweighted_components": {
                "deficit": -deficit,
                "overflow": overflow,
                "starving": starving,
                "wasted_water": wasted,
                "clipping": clipping,
            },
            "cost": 1.0 if (overflow or starving) else 0.0,
            "flood": 1.0 if overflow else 0.0,
            "deficit": deficit,
            "level": level,
            "storage": storage,
            "release": release,
            "action": copy.copy(action) if self._upstream else a,  # never the caller's object itself
            "raw_action": self._raw_action,
            "demand": demand,
            "inflow": inflow,
            "exponential_average_demand": ead,
            "year": self._year,
            "calendar_year": self._ep.calendar_year[t - 1],
            "day_of_year": day,
        }
        if self._upstream:
            self._add_reference_info(info, reward)
        if truncated and self._ep.recorded_level is not None:
            info["recorded_level_rmse"] = self._recorded_level_rmse()
        if self._full_obs:
            obs_level = level if self._current_level_obs else self._levels[self._obs_day[t]]
            return np.array((obs_level, self._sin[t], self._cos[t], ead), _F32), reward, False, truncated, info
        return self._observation(), reward, False, truncated, info

    @staticmethod
    def _add_reference_info(info: dict[str, Any], reward: float) -> None:
        names = {
            "overflow": "overflow_reward",
            "starving": "starving_reward",
            "deficit": "daily_deficit_reward",
            "wasted_water": "wasted_water_reward",
            "clipping": "clipping_reward",
        }
        info["reward"] = reward
        info["pure_reward"] = {names[k]: info["unweighted_components"][k] for k in names}
        info["weighted_reward"] = {names[k]: info["reward_components"][k] for k in names}

    def _recorded_level_rmse(self) -> float:
        recorded = self._ep.recorded_level
        assert recorded is not None
        n = min(len(recorded), len(self._levels))
        return math.sqrt(sum((self._levels[i] - recorded[i]) ** 2 for i in range(n)) / n)

    def render(self) -> str | np.ndarray | None:
        """The current state: ``ansi``, one line of text; ``rgb_array``, an ``H x W x 3`` uint8 frame.

        The text holds year, day, level, storage and average demand; the frame (:mod:`gym4real.dam.rendering`)
        the lake against its thresholds, today's flows and the episode's traces. Both name the day the state
        is at: the start of the first day after ``reset``, else the end of the day just simulated.
        """
        t = self._t
        day = self._obs_day[t - 1 if t else 0] + 1
        if self._renderer is not None:
            ep = self._ep
            return self._renderer.frame(ep.year, day, self._levels, ep.inflow, ep.demand)
        if self.render_mode != "ansi":
            return None
        from gym4real.dam.rendering import day_label

        return (
            f"{self._ep.year} {day_label(day, t)}: level {self._level:+.3f} m, storage {self._storage / 1e6:.1f} Mm3, "
            f"average demand {self._ead:.1f} m3/s\n"
        )
