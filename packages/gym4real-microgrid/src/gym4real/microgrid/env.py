"""MicrogridEnv: a household with PV, a battery (digital twin) and the day-ahead electricity market."""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from gym4real.core.actions import box_value
from gym4real.core.errors import DataFileError
from gym4real.core.perturbation import check_scales
from gym4real.microgrid.battery import BatteryParams, BatteryTwin, TwinOptions, load_battery
from gym4real.microgrid.config import MicrogridConfig
from gym4real.microgrid.data import TRAIN_DEMAND, World, data_path, training_demand, warn_if_fewer_households

if TYPE_CHECKING:
    from gym4real.microgrid.rendering import MicrogridRenderer

SECONDS_PER_DAY = 86400.0
SECONDS_PER_YEAR = 86400.0 * 365.25
TWO_PI = 2.0 * math.pi

#: Observation features in order (``soh`` inserted after ``demand`` when observed) and their bounds.
FEATURES: tuple[tuple[str, float, float], ...] = (
    ("temperature", 250.0, 400.0),
    ("soc", 0.0, 1.0),
    ("demand", 0.0, math.inf),
    ("soh", 0.0, 1.0),
    ("generation", 0.0, math.inf),
    ("ask", 0.0, math.inf),
    ("bid", 0.0, math.inf),
    ("sin_day_of_year", -1.0, 1.0),
    ("cos_day_of_year", -1.0, 1.0),
    ("sin_seconds_of_day", -1.0, 1.0),
    ("cos_seconds_of_day", -1.0, 1.0),
)

TWIN_FIXES = (
    "celsius_lookup",
    "capacity_fade",
    "power_limits",
    "consistent_current",
    "calendar_time",
    "standard_rainflow",
    "thermal_core_state",
)


#: How far outside [0, 1] an action may stray (float rounding) before it is refused; it is then clipped.
ACTION_TOLERANCE = 1e-6
#: What an action means, for the error of an action outside the action space.
ACTIONS = "the fraction of the net power sent to (or taken from) the battery, in [0, 1]"


@functools.lru_cache(maxsize=8)
def _world(
    paths: tuple[Path, Path | None, Path | None, Path | None],
    step: float,
    temp_step: float,
    dummy: tuple[float, float, float, float],
) -> World:
    return World.load(*paths, step=step, temp_step=temp_step, dummy=dummy)


@functools.lru_cache(maxsize=8)
def _battery(data_dir: str | None, files: tuple[str | None, ...]) -> BatteryParams:
    pack, electrical, thermal, aging, tables_dir = files
    return load_battery(data_dir, pack=pack, electrical=electrical, thermal=thermal, aging=aging, tables_dir=tables_dir)


class MicrogridEnv(gym.Env[np.ndarray, np.ndarray]):
    """Home battery management over real data (Gym4ReaL ``MicroGridEnv``).

    ## Description
    A household with a 3 kW PV plant, an hourly electricity demand and a ~21 kWh lithium-ion pack
    (60 Ah, 288-398.4 V) simulated by a digital twin (:mod:`gym4real.microgrid.battery`: Thevenin circuit
    with lookup tables, lumped thermal model, Bolun aging with rainflow cycle counting). Every hour the
    agent chooses which fraction of the net power ``PV - demand`` goes to the battery (surplus) or comes
    from it (deficit); the rest is sold at the GME ``bid`` price or bought at the ``ask`` price. Data:
    demand profiles (W), PV (W), prices (EUR/Wh) hourly, ambient temperature (K) daily; train 2015-2018
    with 370 households (preset ``train``), test 2019 with 28 households 370..397 (presets ``default``,
    ``test``). The real training households (``profiles_train.csv``) are not published where we can
    reach them: without them the ``train`` preset runs on a synthetic stand-in
    (:mod:`gym4real.microgrid.standin`, written by ``gym4real data synthesize microgrid``), and
    ``reset``'s ``info["demand_source"]`` says which (``real`` or ``stand-in``). The ``default`` preset
    draws random episodes from the test households, so that ``make()`` works offline: train on ``train``.

    ## Action Space
    ``Box(0, 1, (1,), float32)``: the fraction ``a`` of the net power routed to (or taken from) the
    battery. The request ``a * (PV - demand)`` is clipped to what the battery can take or give in the
    hour (SoC window, and the pack's current and power bounds); the clipped part is traded instead and
    penalised. NaN or values outside ``[0, 1]`` (beyond 1e-6) raise ``ValueError``.

    ## Observation Space
    ``Box(float32)`` of 10 values (11 with ``observe_soh``), in this order:

    | feature | bounds | meaning |
    |---|---|---|
    | ``temperature`` | [250, 400] K | battery temperature |
    | ``soc`` | [0, 1] | state of charge |
    | ``demand`` | [0, inf) W | demand of the hour just elapsed (estimate of the next) |
    | (``soh``) | [0, 1] | state of health, only with ``observe_soh`` |
    | ``generation`` | [0, inf) W | PV of the hour just elapsed (estimate of the next) |
    | ``ask``, ``bid`` | [0, inf) EUR/Wh | buy and sell prices of the upcoming hour (day-ahead) |
    | ``sin/cos_day_of_year`` | [-1, 1] | angle ``2 pi t / 365.25 d`` |
    | ``sin/cos_seconds_of_day`` | [-1, 1] | angle ``2 pi t / 1 d`` |

    ## Rewards
    ``reward = w_trad * trading + w_deg * degradation + w_clip * clipping`` with

    * trading (EUR): ``bid * sold - ask * bought`` over the hour;
    * degradation (EUR): ``-(SoH drop) / (1 - eol_soh) * replacement_cost`` (3000 EUR);
    * clipping (Wh): ``-|requested - applied battery energy|``;

    weights from ``reward`` (1 / 1 / 0.1); with ``reward.normalize`` trading is divided by
    ``max(max PV * max bid, max demand * max ask)`` and clipping by the largest net power of the data.
    ``info["reward_components"]`` holds the three weighted terms (they sum to the reward) and
    ``info["pure_components"]`` the same unweighted and unnormalised. ``info["cost"]`` is the SoC-window
    violation: how far beyond ``[soc_min, soc_max]`` the requested energy would have driven the SoC.
    The paper's objective is ``trading + degradation`` in EUR (the ``test`` preset's return).

    ## Starting State
    The profile is ``options["profile"]`` (or the reference's ``options["eval_profile"]``), else drawn
    with the reset seed (``profile_order: random``) or taken in file order (``sequential``; the ``test``
    preset). The episode starts at the second data hour (or a random hour with ``random_start``,
    or ``options["start"]``), the battery at SoC 0.2, SoH 1 and the ambient temperature of the day (or
    drawn within the pack's bounds with ``random_battery_init``).

    ## Episode End
    Termination when the state of health reaches ``battery.eol_soh`` (0.6, end of life); truncation when
    the data is exhausted (the first data hour is only observed: 8759 hourly steps on the 2019 data) or
    after ``max_steps`` data steps. With ``decision_interval = k`` each step holds the action for ``k``
    data steps (the reward sums them), so an episode has ``ceil(steps / k)`` decisions.

    ## Arguments
    ``gymnasium.make("gym4real/microgrid-v0", config=None, preset=None, render_mode=None, **overrides)``:
    ``config`` is a :class:`MicrogridConfig`, a mapping or a YAML path; ``preset`` is ``default``,
    ``train`` or ``test``; overrides are config fields (``fidelity="upstream"``, ``decision_interval=4``,
    ``reward={"normalize": False}``, ``fixes={"capacity_fade": False}``, ...).
    ``render_mode="rgb_array"`` draws 480 x 320 frames (SoC, temperature and SoH, the step's power flows,
    prices, cumulative profit and degradation).

    Perturbable parameters (:meth:`perturb`, used by :class:`gym4real.wrappers.ExogenousPerturbation`):
    ``battery_capacity`` (the nominal capacity in Ah), ``energy_price`` (the ask and bid series),
    ``demand`` (the load profiles) and ``generation`` (the PV series), in both fidelity modes.

    ## Corrected mode and ``fidelity="upstream"``
    The default mode fixes the reference's defects (numbers refer to the spec); each fix is a switch in
    ``fixes`` (null follows ``fidelity``), and ``fidelity="upstream"`` turns them all off:

    1. ``celsius_lookup``: the ECM tables are in °C; corrected converts the kelvin temperature and
       interpolates bilinearly; upstream takes the nearest grid point of the raw kelvin value (always
       the 40 °C column at the nearest 5 % SoC).
    2. ``capacity_fade``: coulomb counting and the SoC limits use ``SoH * 60 Ah``; upstream always 60 Ah.
    3. ``power_limits``: the pack's current (-180..60 A) and power bounds limit the battery too;
       upstream only the SoC window does.
    4. ``consistent_current``: the current solves ``V(I) I = P`` with the new terminal voltage (the
       battery takes exactly the traded-off energy, energy is conserved) from a rest voltage equal to
       the OCV; upstream ``I = P / V_previous`` from 310.8 V.
    5. ``data_alignment``: every series indexed by its own length and the ambient temperature of the
       simulated hour's day; upstream PV, prices and temperature wrap at ``len - 1`` (the last row is
       never used: the final step trades at 1 January's prices) and the temperature is the next hour's.
    6. ``calendar_time``: calendar aging integrated over each step; upstream uses the previous step's
       elapsed time (-1 s at the first step) with running means of SoC and temperature.
    7. ``standard_rainflow``: streaming ASTM rainflow from the initial SoC keeping the residue's half
       cycles, SoH never increases, and the degradation cost is charged on the SoH drop; upstream's
       Dropflow drops half cycles (SoH can rise) and charges ``|ΔSoH|``.
    8. ``thermal_core_state``: the core temperature is the thermal state (observed; the surface is in
       ``info["battery"]``) and dV/dT is taken at the new SoC; upstream feeds the surface temperature
       back as the core's and uses the previous SoC.
    9. Seeding: the profile, the start and a random initial battery come from ``reset(seed=)``;
       upstream draws them from a generator seeded once with ``upstream_seed`` (42) at construction,
       as the reference's global NumPy seed (``reset(seed)`` has no effect; one generator per env, where
       the reference's envs of one process share the global one), folds the start time to the first
       year (12) and ignores ``profile_order``.

    Missing series (11): the reference runs without market or temperature files on constants, but its
    constant generation crashes. Corrected: ``data.generation``, ``data.market`` or ``data.temp_amb`` set to
    null use the constants of ``data.dummy`` (10 W of PV, 0.21 / 0.14 EUR/kWh, 298.15 K: the reference's
    training values) over the hours of the other files; upstream needs generation data.

    Both modes: fresh ``info`` dicts every step and no mutation of the data (10); the episode length is
    explicit (``max_steps``); a missing or malformed data file
    raises ``DataFileError`` naming the file (13); the first data row is only observed (14); table
    lookups are precomputed Python arithmetic, no SciPy in the step (15).

    ## Version History
    * v0: Gym4ReaL v1.0 dynamics, corrected by default.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 8}
    reward_component_names = ("trading", "degradation", "clipping")
    perturbable = ("battery_capacity", "energy_price", "demand", "generation")

    def __init__(
        self,
        config: MicrogridConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        self.config = cfg = MicrogridConfig.build(config, preset, **overrides)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, not {render_mode!r}")
        self.render_mode = render_mode
        self._upstream = cfg.fidelity == "upstream"
        self._aligned = cfg.fix("data_alignment")
        self._soh_cost = cfg.fix("standard_rainflow")
        self.demand_source = "real"
        self.world = self._load_world()
        b = cfg.battery
        files = (b.pack, b.electrical, b.thermal, b.aging, b.tables_dir)
        self.battery_params = _battery(cfg.data_dir, files)
        options = TwinOptions.for_fidelity(cfg.fidelity, **{k: getattr(cfg.fixes, k) for k in TWIN_FIXES})
        self.battery = BatteryTwin(self.battery_params, options, eol_soh=b.eol_soh)
        self._renderer: MicrogridRenderer | None = None
        if render_mode == "rgb_array":
            from gym4real.microgrid.rendering import MicrogridRenderer

            bp = self.battery_params
            self._renderer = MicrogridRenderer(bp.soc_min, bp.soc_max, b.eol_soh, cfg.data.timestep / 3600.0)
        self._scales: dict[str, float] = dict.fromkeys(self.perturbable, 1.0)
        self._pending_scales = self._scales

        w = self.world
        labels = w.labels
        if cfg.profiles is not None:
            unknown = [p for p in cfg.profiles if p not in labels]
            if unknown:
                msg = f"`profiles` {unknown} are not columns of the demand file; available: {list(labels)}"
                raise DataFileError(msg)
            labels = tuple(cfg.profiles)
        self.profiles = labels
        self._n_rows = len(w.pv)
        self._n_demand = len(w.demand)
        self._n_temp = len(w.temp)
        self._hour_mod = self._n_rows if self._aligned else self._n_rows - 1
        self._day_mod = self._n_temp if self._aligned else self._n_temp - 1
        self._step_s = w.step
        self._hours_per_step = w.step / 3600.0
        self._trading_scale = 1.0 / w.trading_norm if cfg.reward.normalize else 1.0
        self._clipping_scale = 1.0 / w.clipping_norm if cfg.reward.normalize else 1.0
        self._deg_per_soh = b.replacement_cost / (1.0 - b.eol_soh)
        self._weights = (cfg.reward.trading, cfg.reward.degradation, cfg.reward.clipping)

        features = [f for f in FEATURES if f[0] != "soh" or cfg.observe_soh]
        self.feature_names = tuple(f[0] for f in features)
        self.observation_space = spaces.Box(
            low=np.array([f[1] for f in features], dtype=np.float32),
            high=np.array([f[2] for f in features], dtype=np.float32),
            dtype=np.float32,
        )
        self.action_space = spaces.Box(low=0.0, high=1.0, shape=(1,), dtype=np.float32)
        self._legacy_rng = np.random.RandomState(cfg.upstream_seed)
        self._cursor = 0
        self._profile = labels[0]
        self._apply_scales()
        self._demand = self._profile_series(self._profile)
        self._start(1, self.battery_params.init_soc, self.battery_params.init_soh, None)

    def _load_world(self) -> World:
        cfg = self.config
        d = cfg.data
        paths: list[Path | None] = []
        for what in ("demand", "generation", "market", "temp_amb"):
            ref = getattr(d, what)
            if ref is None:  # the constant of `data.dummy`
                paths.append(None)
                continue
            if ref == TRAIN_DEMAND:
                path, self.demand_source = training_demand(cfg.data_dir)
                if self.demand_source == "stand-in":
                    warn_if_fewer_households(path)
                paths.append(path)
                continue
            paths.append(data_path(ref, cfg.data_dir))
        dummy = (d.dummy.generation, d.dummy.ask, d.dummy.bid, d.dummy.temp_amb)
        return _world(tuple(paths), d.timestep, d.temp_timestep, dummy)  # type: ignore[arg-type]

    # -- exogenous perturbation ----------------------------------------------------------------------

    def perturb(self, scales: Mapping[str, float]) -> None:
        """Scale domain parameters from their nominal values, from the next :meth:`reset` on.

        Args:
            scales: Multipliers of the nominal values, by name (those of :attr:`perturbable`; a missing
                name is 1.0): ``battery_capacity`` scales the pack's nominal capacity (Ah) in coulomb
                counting and the SoC limits; ``energy_price`` the ask and bid series (observed and
                traded; the reward's normaliser stays the nominal data's); ``demand`` and ``generation``
                the load profiles and the PV series. Scales never compound: each call replaces the
                previous one, and ``perturb({})`` restores the nominal model exactly.

        Raises:
            ValueError: An unknown name, or a scale that is not a finite positive number.
        """
        self._pending_scales = check_scales(scales, self.perturbable)

    @property
    def scales(self) -> dict[str, float]:
        """The perturbation scales of the current episode's model (1.0: nominal)."""
        return dict(self._scales)

    def _apply_scales(self) -> None:
        """Bring the scaled series and battery into use (at a reset); 1.0 keeps the nominal objects."""
        self._scales = scales = self._pending_scales
        w = self.world
        price, gen = scales["energy_price"], scales["generation"]
        self._ask = w.ask if price == 1.0 else [v * price for v in w.ask]
        self._bid = w.bid if price == 1.0 else [v * price for v in w.bid]
        self._pv = w.pv if gen == 1.0 else [v * gen for v in w.pv]
        params = self.battery_params
        capacity = scales["battery_capacity"]
        if capacity != 1.0:
            params = dataclasses.replace(params, nominal_capacity=params.nominal_capacity * capacity)
        if self.battery.params is not params:
            self.battery = BatteryTwin(params, self.battery.options, eol_soh=self.battery.eol_soh)

    def _profile_series(self, label: str) -> list[float]:
        """The demand profile ``label`` (W per row), scaled by the ``demand`` perturbation."""
        series = self.world.profile(label)
        factor = self._scales["demand"]
        return series if factor == 1.0 else [v * factor for v in series]

    # -- episode start -------------------------------------------------------------------------------

    def _start(self, row: int, soc: float, soh: float, temperature: float | None) -> None:
        """Place the episode at data row ``row`` (the upcoming hour) with a battery at rest."""
        cfg = self.config
        if self._upstream:  # the reference folds the start time into the first year
            row = int(row * self._step_s % SECONDS_PER_YEAR // self._step_s)
        self._row = row
        self._iterations = 0
        if temperature is None:
            temperature = self.world.temp[self._day(row * self._step_s)]
        if self._upstream:
            self._limit = self._n_rows - 1 if cfg.max_steps is None else cfg.max_steps
        else:
            self._limit = min(self._n_rows - row, cfg.max_steps or self._n_rows)
        self.battery.reset(soc=soc, temperature=temperature, soh=soh)

    def _day(self, seconds: float) -> int:
        """Row of the daily temperature series at a time (the reference wraps at ``len - 1`` days)."""
        return int(seconds // self.world.temp_step) % self._day_mod

    def _option_profile(self, options: Mapping[str, Any]) -> str | None:
        """The profile named by ``options`` (``profile`` or ``eval_profile``), checked; None if none is."""
        profile = options.get("profile", options.get("eval_profile"))
        if profile is None:
            return None
        if str(profile) not in self.world.labels:
            msg = f"`options['profile']` {profile!r} is not a demand column; available: {list(self.world.labels)}"
            raise ValueError(msg)
        return str(profile)

    def _option_start(self, options: Mapping[str, Any]) -> int | None:
        """The start row named by ``options['start']``, checked; None if none is."""
        if "start" not in options:
            return None
        row = int(options["start"])
        if not 1 <= row < self._n_rows:
            raise ValueError(f"`options['start']` must be a data row in [1, {self._n_rows - 1}], not {row}")
        return row

    def draw_start(
        self, options: Mapping[str, Any], rng: np.random.Generator, cursor: int
    ) -> tuple[str, int, int | None, tuple[float, float, float] | None]:
        """Draw an episode start as the corrected mode does (the batched env draws each copy's with it).

        Args:
            options: The reset options (``profile``/``eval_profile``, ``start``); what they name is not drawn.
            rng: The generator of the draws, in the order profile, start row, SoC, SoH, temperature.
            cursor: The position in the profile list of ``profile_order: sequential``.

        Returns:
            The profile label, the start row, the next cursor (None when the options chose the profile) and
            the battery's (SoC, SoH, temperature), None for the pack's initial state.
        """
        cfg, labels = self.config, self.profiles
        profile, next_cursor = self._option_profile(options), None
        if profile is None:
            if cfg.profile_order == "sequential":
                profile, next_cursor = labels[cursor], (cursor + 1) % len(labels)
            else:
                profile = labels[int(rng.integers(len(labels)))]
        row = self._option_start(options)
        if row is None:
            row = int(rng.integers(1, self._n_rows - 1)) if cfg.random_start else 1
        battery = None
        if cfg.random_battery_init:
            bounds = self.battery_params.bounds()
            soc, soh, temperature = (float(rng.uniform(*bounds[k])) for k in ("soc", "soh", "temperature"))
            battery = (soc, soh, temperature)
        return profile, row, next_cursor, battery

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """Start an episode: choose the profile, the start hour and the initial battery state."""
        super().reset(seed=seed)
        options = dict(options or {})
        cfg = self.config
        p = self.battery_params
        labels = self.profiles
        rng = self._legacy_rng if self._upstream else None
        soc, soh, temperature = p.init_soc, p.init_soh, None
        if rng is not None:
            profile = self._option_profile(options)
            if profile is None:
                profile = str(rng.choice(list(labels)))
            row = self._option_start(options)
            if row is None:
                row = int(rng.randint(1, self._n_rows - 1)) if cfg.random_start else 1
            if cfg.random_battery_init:  # the reference draws every bound, in the pack's order
                draws = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in p.bounds().items()}
                soc, soh, temperature = draws["soc"], draws["soh"], draws["temperature"]
        else:
            cursor = self._cursor if seed is None else seed % len(labels)
            profile, row, next_cursor, battery = self.draw_start(options, self.np_random, cursor)
            if next_cursor is not None:
                self._cursor = next_cursor
            if battery is not None:
                soc, soh, temperature = battery
        self._profile = profile
        self._apply_scales()
        self._demand = self._profile_series(profile)
        self._start(row, soc, soh, temperature)
        if rng is not None and cfg.random_battery_init:
            self.battery.voltage = draws["voltage"]
        if self._renderer is not None:
            self._renderer.start(self.battery.soc)
        zeros = {"trading": 0.0, "degradation": 0.0, "clipping": 0.0}
        info = {
            "profile": profile,
            "start": self._row,
            "soc": self.battery.soc,
            "soh": self.battery.soh,
            "reward_components": zeros,
            "pure_components": dict(zeros),
            "cost": 0.0,
            "demand_source": self.demand_source,
        }
        return self._obs(), info

    # -- observation ---------------------------------------------------------------------------------

    def _obs(self) -> np.ndarray:
        bat = self.battery
        row = self._row
        now = row % self._hour_mod
        prev = (row - 1) % self._hour_mod
        temp = bat.temperature
        temp = 250.0 if temp < 250.0 else 400.0 if temp > 400.0 else temp
        tau = row * self._step_s
        year = TWO_PI * tau / SECONDS_PER_YEAR
        day = TWO_PI * tau / SECONDS_PER_DAY
        values = [
            temp,
            bat.soc,
            self._demand[(row - 1) % self._n_demand],
            self._pv[prev],
            self._ask[now],
            self._bid[now],
        ]
        if self.config.observe_soh:
            values.insert(3, min(max(bat.soh, 0.0), 1.0))
        values += [math.sin(year), math.cos(year), math.sin(day), math.cos(day)]
        return np.array(values, dtype=np.float32)

    # -- dynamics ------------------------------------------------------------------------------------

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Route the fraction ``action`` of the net power to the battery for ``decision_interval`` hours."""
        a = box_value(action, self.action_space, ACTIONS, tolerance=ACTION_TOLERANCE)

        w, bat = self.world, self.battery
        dt = self._step_s
        hours = self._hours_per_step
        demand_series, pv, ask, bid = self._demand, self._pv, self._ask, self._bid
        temp_series, temp_step = w.temp, w.temp_step
        hour_mod, day_mod, n_demand = self._hour_mod, self._day_mod, self._n_demand
        shift = 0 if self._aligned else 1
        trading = degradation = clipping = cost = 0.0
        e_demand = e_pv = e_in = e_out = e_sold = e_bought = 0.0
        terminated = truncated = False
        for _ in range(self.config.decision_interval):
            r = self._row
            now = r % hour_mod
            demand = demand_series[r % n_demand]
            # the ambient temperature of the simulated hour (the reference: of the next hour)
            t_amb = temp_series[int((r + shift) * dt // temp_step) % day_mod]
            gen = pv[now]
            margin = gen - demand
            request = margin * a
            soh0 = bat.soh
            applied = bat.step(request, dt, t_amb)
            traded = margin - applied
            if traded < 0.0:
                trading += traded * ask[now] * hours
                e_bought -= traded * hours
            else:
                trading += traded * bid[now] * hours
                e_sold += traded * hours
            if self._soh_cost:
                degradation -= (soh0 - bat.soh) * self._deg_per_soh
            else:
                degradation -= abs(soh0 - bat.soh) * self._deg_per_soh
            clipping -= abs(request - applied) * hours
            cost += bat.soc_violation
            e_demand += demand * hours
            e_pv += gen * hours
            if applied > 0.0:
                e_in += applied * hours
            else:
                e_out -= applied * hours
            self._row += 1
            self._iterations += 1
            terminated = bat.soh <= bat.eol_soh
            truncated = self._iterations >= self._limit
            if terminated or truncated:
                break

        wt, wd, wc = self._weights
        comps = {
            "trading": wt * trading * self._trading_scale,
            "degradation": wd * degradation,
            "clipping": wc * clipping * self._clipping_scale,
        }
        info = {
            "profile": self._profile,
            "soc": bat.soc,
            "soh": bat.soh,
            "temperature": bat.temperature,
            "reward_components": comps,
            "pure_components": {"trading": trading, "degradation": degradation, "clipping": clipping},
            "cost": cost,
            "energy": {
                "demand": e_demand,
                "pv": e_pv,
                "to_battery": e_in,
                "from_battery": e_out,
                "sold": e_sold,
                "bought": e_bought,
            },
            "battery": bat.snapshot(),
        }
        if self._renderer is not None:
            self._renderer.record(
                cast("dict[str, float]", info["energy"]), trading, degradation, bat.soc, self._iterations
            )
        reward = comps["trading"] + comps["degradation"] + comps["clipping"]
        return self._obs(), reward, terminated, truncated and not terminated, info

    def render(self) -> np.ndarray | None:
        """The ``H x W x 3`` uint8 frame of ``render_mode="rgb_array"`` (else None).

        The frame (:mod:`gym4real.microgrid.rendering`) shows SoC, temperature and SoH, the last step's power
        flows (PV, demand, battery, grid), the coming hour's prices, the cumulative profit and degradation.
        """
        if self._renderer is None:
            return None
        bat, now = self.battery, self._row % self._hour_mod
        seconds = self._row * self._step_s
        return self._renderer.frame(
            self._profile, seconds, bat.soc, bat.soh, bat.temperature, self._ask[now], self._bid[now]
        )
