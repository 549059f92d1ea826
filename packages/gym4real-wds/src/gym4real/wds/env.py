"""WDSEnv: pump scheduling of a water distribution network simulated by EPANET (Anytown by default)."""

from __future__ import annotations

import math
import weakref
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from gym4real.core.actions import DiscreteAction
from gym4real.core.datasets import resolve
from gym4real.core.errors import ConfigError
from gym4real.core.perturbation import check_scales
from gym4real.wds import demand
from gym4real.wds import engine as en
from gym4real.wds.config import WDSConfig
from gym4real.wds.network import PumpRule, add_pump_controls, describe, disable_pump_controls, pump_controls

PATTERN_ID = "gym4real_demand"
DAY = 86_400.0
OPTIONS = ("pattern", "profile_index", "is_evaluation")


class WDSEnv(gym.Env[np.ndarray, np.int64]):
    """Switch the pumps of a water distribution network to keep demand satisfied without overfilling tanks.

    ## Description
    Gym4ReaL's ``WDSEnv``: the Anytown network (22 junctions, reservoir R40, elevated tanks T41 and T42,
    parallel pumps P78 and P79) under one week of demand, simulated by EPANET 2.3 (owa-epanet; epyt's
    library as fallback) as one continuous extended-period, pressure-driven simulation. Junction base
    demands follow an hourly multiplier profile drawn at each reset: a week of a training file from the
    ``normal`` / ``stressful`` / ``extreme`` buckets (probabilities 0.6 / 0.35 / 0.05), or one of the
    1,000 held-out test profiles (``options={"profile_index": k}``). Any EPANET network can be used with
    ``network="path.inp"``: its junctions, tanks and pumps are found in the file.

    ## Action Space
    ``Discrete(2**P)`` for P pumps: the action's bits, most significant first, open (1) or close (0) the
    pumps in EPANET's link order. Anytown: 0 both off, 1 P79 only, 2 P78 only, 3 both on. Anything else
    (a float, NaN, out of range) raises ``ValueError``.

    ## Observation Space
    ``Box(float32)`` of ``L + J + 3`` entries (27 for Anytown):

    | entries | value | bounds |
    |---|---|---|
    | tanks (L) | water level (EPANET tank pressure; ``EN_TANKLEVEL`` is the initial level) | [min level, max level] |
    | junctions (J) | pressure, all junctions or ``observation.junctions`` | [lowest head, highest head] - elevation |
    | 1 | demand estimate: SMA (or EWMA) of the multipliers over the last ``demand.window`` hours | profile range |
    | 2 | sin, cos of the time of day (the reference's order) | [-1, 1] |

    Values are clipped into the bounds. The head bounds are physical: the lowest source head or node
    elevation, and the highest source head plus every pump's shutoff head. EPANET exceeds them only for a
    network without an outlet, which happens in profiles with negative multipliers (injections) while both
    tanks are full: the solver then reports pressures of 10^4-10^5 m.

    ## Rewards
    ``dsr_coeff * DSR - overflow_coeff * OVF`` (``reward.*``), components in ``info["reward_components"]``.
    DSR = delivered / full demand over all junctions (1 when nothing is demanded); OVF = sum over tanks of
    ``max(0, level - lambda_of * max) / ((1 - lambda_of) * max)``, in [0, L]. ``lambda_of`` is 0.95, what the
    reference code runs; the paper's Table 9 says 0.9. Both are averaged over the decision interval,
    weighted by the duration of EPANET's sub-steps (OVF integrated exactly along the linear level
    trajectory of each sub-step). ``info["cost"]`` is OVF.

    ## Starting State
    Tanks at their initial levels, pumps at their initial status, time 0; the observation is the network
    solved at t = 0 with the pumps' initial status.

    ## Episode End
    Truncation after ``duration / decision_interval`` decisions (168); no termination. The final
    observation comes from a solve at t = ``duration``.

    ## Arguments
    ``gymnasium.make("gym4real/wds-v0", config=None, preset=None, render_mode=None, **overrides)``: presets
    ``default`` (reference weights 1 / 0.25), ``train`` (weights 1 / 1, as the reference DQN),
    ``validation`` and ``test`` (test profiles, weights 1 / 1 so that the return is the paper's
    cumulative DSR - OVF). Overrides are :class:`~gym4real.wds.config.WDSConfig` fields. Reset options:
    ``profile_index`` (test profile), ``is_evaluation`` (a random test profile), ``pattern`` (your own
    multipliers, within the profiles' range). ``render_mode``: ``ansi`` (a text line) or ``rgb_array``
    (tank gauges and pump lamps). Perturbable parameters (:meth:`perturb`, both modes): ``pump_curve``
    (the head of every pump's head curve) and ``demand`` (the episode's demand multipliers); pressures
    and demand estimates they push past the observation bounds are clipped like any other value.

    ## Corrected mode and ``fidelity="upstream"``
    The default fixes the reference's defects; ``fidelity="upstream"`` restores them (``fixes.*`` switch
    the numeric ones one by one):

    1. Stepping (``fixes.fixed_interval``): corrected, one step per ``decision_interval`` with EPANET's
       intermediate events (tanks filling or draining) handled inside and DSR / OVF time-weighted;
       EPANET integrates tank levels (explicit Euler) every ``hydraulic_step`` = 600 s, within 0.2 m of a
       converged 60 s run over a week (preset ``hourly_hydraulics``: 3600 s, 1.1-1.6 m off);
       upstream, one step per EPANET event with the hydraulic step clamped by the file's 600 s report step,
       so ~1,009+ steps of variable duration, observation mixing tank levels at t + dt with pressures at t,
       and truncation at the solve at t = duration.
    2. DSR reference (``fixes.dsr_reference``): corrected, the current multiplier; upstream, the hour-0
       demand all week (0 when it is not positive; DSR may then be negative with negative multipliers).
    3. Demand estimate (``fixes.per_episode_estimate``): corrected, per episode; upstream, the first
       episode's, reused.
    4. Reset observation (``fixes.initial_observation``): corrected, solved; upstream, zeros for tanks and
       pressures.
    5. Seeding: corrected, draws from ``self.np_random``; upstream, from a private legacy generator seeded
       with ``seed`` (42) and re-seeded by ``reset(seed=)`` (the reference used the global one).
    6. Tank events (``fixes.exact_tank_events``): EPANET rounds the time until a tank empties or fills to
       whole seconds and ignores events under half a second, so an all-but-empty tank (a few litres) keeps
       supplying the network for a whole hydraulic step (DSR 1 with empty tanks and pumps off, water
       created from nothing). Corrected: such a tank is set to its limit before the solve, and the tanks'
       volume change equals pumped minus delivered volume. Upstream: EPANET's behaviour.
    7. Engine life cycle: one project per env, report file in a private temporary folder (removed at
       once on POSIX), a fresh hydraulic solver per episode (``closeH``/``openH``/``initH`` with the link
       flows re-initialised: ``initH(0)`` alone carries solver state across episodes and breaks same-seed
       determinism), everything
       released by ``close()`` or garbage collection (both modes).
    8. Information: pump statuses, tank levels, volumes and the profile in ``info`` (both modes); no print.
    9. Observation bounds hold in both modes (the reference's Box is violated by its own values).

    Controls and rules of the network that switch pumps are disabled: the agent alone acts. The
    ``[CONTROLS]`` tank-level rule (commented out in Anytown) is parsed for the ``default`` baseline, which
    applies it at the hourly decisions, hence only approximately: a pump switches at the first decision
    after its tank crosses a level, so tanks overshoot and, over a week, tank levels drift 4.6-7.8 m from
    EPANET executing the controls (test profiles 0-19), the DSR up to 0.9 %. The exact expert is
    ``pump_control="controls"``: EPANET executes the network's pump controls itself all episode (Anytown:
    the commented rule, added as controls), switching a pump the moment its tank crosses a level; the
    action is then checked but not applied, and ``info["pumps"]`` holds the statuses EPANET set at the
    start of the interval (it may switch again inside it). With ``fixes.exact_tank_events`` off the episode
    is EPANET's own run of the file with its controls active, bit for bit; on (corrected), it departs from
    it only where a tank reaches a limit.

    ## Version History
    * v0: Gym4ReaL v1.0 dynamics on EPANET 2.3.05, corrected by default.
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}
    reward_component_names = ("dsr", "overflow")
    perturbable: tuple[str, ...] = ("pump_curve", "demand")

    def __init__(
        self,
        config: WDSConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        self.config = cfg = WDSConfig.build(config, preset, **overrides)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, not {render_mode!r}")
        self.render_mode = render_mode
        up = cfg.fidelity == "upstream"
        fx = cfg.fixes
        self._upstream = up
        self._fixed = (not up) if fx.fixed_interval is None else fx.fixed_interval
        self._first_hour = (fx.dsr_reference or ("first_hour" if up else "current")) == "first_hour"
        self._per_episode_estimate = (not up) if fx.per_episode_estimate is None else fx.per_episode_estimate
        self._zero_reset = (fx.initial_observation or ("zeros" if up else "solved")) == "zeros"
        self._exact_events = (not up) if fx.exact_tank_events is None else fx.exact_tank_events

        self.profiles = demand.load(cfg.data_dir)
        path = Path(cfg.network).expanduser() if cfg.network else resolve("wds/anytown", cfg.data_dir)
        self._engine = en.Engine(path, cfg.engine)
        self._finalizer = weakref.finalize(self, self._engine.close)
        try:
            self._setup()
        except BaseException:
            self.close()
            raise

    # -- construction ------------------------------------------------------------------------------

    def _setup(self) -> None:
        cfg, eng = self.config, self._engine
        tk, ph = eng.tk, eng.ph
        self.network = net = describe(eng)
        rules = net.rules_from_file or tuple(PumpRule(r.pump, r.tank, r.low, r.high) for r in self.config.default_rule)
        self.pump_rules: tuple[PumpRule, ...] = rules
        self.pump_rules_source = "network [CONTROLS]" if net.rules_from_file else "config `default_rule`"
        self._agent_pumps = cfg.pump_control == "agent"
        self.disabled_controls = self.added_controls = 0
        if self._agent_pumps:
            self.disabled_controls = disable_pump_controls(eng, net)
        elif not any(pump_controls(eng, net)):  # no active pump control: EPANET executes the tank-level rule
            self.added_controls = add_pump_controls(eng, net, rules)
        self.engine_label = eng.label

        if cfg.observation.junctions is None:
            observed = list(range(len(net.junction_ids)))
        else:
            unknown = [j for j in cfg.observation.junctions if j not in net.junction_ids]
            if unknown:
                msg = f"`observation.junctions` names {unknown}, not junctions of `{net.path.name}`: {net.junction_ids}"
                raise ConfigError(msg)
            observed = [net.junction_ids.index(j) for j in cfg.observation.junctions]
        self._obs_junction_pos = net.junction_pos[observed]

        # Pressure-driven analysis, with the file's parameters unless the config overrides them.
        _, pmin, preq, pexp = tk.getdemandmodel(ph)
        p = cfg.pda
        self.pda = (
            p.minimum_pressure if p.minimum_pressure is not None else pmin,
            p.required_pressure if p.required_pressure is not None else preq,
            p.exponent if p.exponent is not None else pexp,
        )
        if self.pda[1] <= self.pda[0]:
            msg = f"PDA required pressure ({self.pda[1]}) must exceed the minimum pressure ({self.pda[0]}); set `pda.*`"
            raise ConfigError(msg)
        tk.setdemandmodel(ph, en.PDA, *self.pda)

        # Times: report and pattern steps first, since EPANET clamps the hydraulic step by both.
        tk.settimeparam(ph, en.DURATION, cfg.duration)
        tk.settimeparam(ph, en.PATTERNSTEP, cfg.pattern_step)
        tk.settimeparam(ph, en.PATTERNSTART, 0)
        if self._fixed:
            tk.settimeparam(ph, en.REPORTSTEP, cfg.decision_interval)
            expected = min(cfg.hydraulic_step, cfg.decision_interval, cfg.pattern_step)
        else:  # the reference keeps the file's report step (600 s for Anytown)
            expected = min(cfg.hydraulic_step, tk.gettimeparam(ph, en.REPORTSTEP), cfg.pattern_step)
        tk.settimeparam(ph, en.HYDSTEP, cfg.hydraulic_step)
        self.effective_hydraulic_step = int(tk.gettimeparam(ph, en.HYDSTEP))
        if self.effective_hydraulic_step != expected:
            msg = f"EPANET set the hydraulic step to {self.effective_hydraulic_step} s, expected {expected} s"
            raise en.EpanetError(msg)

        # One demand pattern on every demand category of every junction.
        tk.addpattern(ph, PATTERN_ID)
        self._pattern_index = tk.getpatternindex(ph, PATTERN_ID)
        for j in net.junction_pos + 1:
            for d in range(1, tk.getnumdemands(ph, int(j)) + 1):
                tk.setdemandpattern(ph, int(j), d, self._pattern_index)

        self._junctions = np.asarray(net.junction_pos)  # the nodes whose demand the DSR counts
        self._flow_to_m3h = net.flow_to_m3h
        self._lambda = cfg.reward.lambda_of
        self._ovf_start = self._lambda * net.tank_max_level
        self._ovf_scale = (1.0 - self._lambda) * net.tank_max_level
        self._n_pumps = len(net.pump_ids)
        self._tank_nodes = tuple(int(i) + 1 for i in net.tank_pos)
        self._q_to_volume = net.flow_to_volume_per_second
        # Snapping a tank (exact tank events) sets its initial level through the toolkit, and the next reset
        # sets it back; the file's own initial head can differ from a toolkit-set one in the last bit, so the
        # toolkit sets it from the start and every episode begins from the same state.
        self._tanks_moved = self._exact_events
        self._decisions = cfg.duration // cfg.decision_interval

        n_t, n_j = len(net.tank_ids), len(observed)
        elev = net.junction_elevation[observed]
        low = np.concatenate([net.tank_min_level, net.head_low - elev, [self.profiles.low, -1.0, -1.0]]).astype(
            np.float64
        )
        high = np.concatenate([net.tank_max_level, net.head_high - elev, [self.profiles.high, 1.0, 1.0]]).astype(
            np.float64
        )
        self._low, self._high = low, high
        self._n_tanks, self._n_obs_junctions = n_t, n_j
        self.observation_space = spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)
        self.action_space = spaces.Discrete(2**self._n_pumps)
        self._action = DiscreteAction(
            self.action_space,
            f"0..{2**self._n_pumps - 1}, whose {self._n_pumps} bits (most significant first) open (1) or close (0) "
            "the pumps",
        )
        self.observation_names = (
            *net.tank_ids,
            *(net.junction_ids[i] for i in observed),
            "demand_estimate",
            "sin_time_of_day",
            "cos_time_of_day",
        )

        self._head_curves, self._pump_powers = self._nominal_pumps()
        self._scales = dict.fromkeys(self.perturbable, 1.0)

        self._legacy_rng = np.random.RandomState(cfg.seed)
        self._estimate: np.ndarray | None = None
        self._pattern = np.ones(demand.HOURS)
        self._m_ref = 1.0
        self._profile = ""
        self._t = 0
        self._done = True
        self._statuses = net.pump_initial_status
        self._levels = net.tank_min_level.copy()
        self._last_info: dict[str, Any] = {}

    def _nominal_pumps(self) -> tuple[dict[int, list[tuple[float, float]]], dict[int, float]]:
        """The file's head curve points of the pumps (once per curve), the power of constant-power pumps."""
        tk, ph = self._engine.tk, self._engine.ph
        curves: dict[int, list[tuple[float, float]]] = {}
        powers: dict[int, float] = {}
        for link in self.network.pump_index:
            if tk.getpumptype(ph, link) == en.CONST_HP:
                powers[link] = float(tk.getlinkvalue(ph, link, en.PUMP_POWER))
                continue
            curve = int(tk.getheadcurveindex(ph, link))
            if curve > 0 and curve not in curves:
                points = (tk.getcurvevalue(ph, curve, k) for k in range(1, tk.getcurvelen(ph, curve) + 1))
                curves[curve] = [(float(x), float(y)) for x, y in points]
        return curves, powers

    # -- pickling: rebuild the engine from the config ------------------------------------------------

    def __getstate__(self) -> dict[str, Any]:
        return {"config": self.config, "render_mode": self.render_mode, "spec": self.spec, "scales": self._scales}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(state["config"], render_mode=state["render_mode"])  # type: ignore[misc]
        self.spec = state["spec"]
        self.perturb(state["scales"])

    # -- exogenous perturbation ----------------------------------------------------------------------

    def perturb(self, scales: Mapping[str, float]) -> None:
        """Scale domain parameters from the next ``reset()`` on, until the next call.

        Scales multiply the network file's (nominal) values, never the current ones: a call replaces the
        previous one, and ``perturb({})`` restores the nominal network.

        Args:
            scales: Multipliers by name (missing names are 1). ``pump_curve`` multiplies the head of every
                point of every pump's head curve (for a constant-power pump, whose head is power / flow,
                its power); ``demand`` multiplies the episode's demand multipliers, so the junctions'
                demands, the DSR reference and the observation's demand estimate.

        Raises:
            ValueError: A name not in ``perturbable``, or a scale that is not a finite positive number.
        """
        self._scales = check_scales(scales, self.perturbable)

    def _apply_pump_scale(self) -> None:
        tk, ph, s = self._engine.tk, self._engine.ph, self._scales["pump_curve"]
        for curve, points in self._head_curves.items():
            for k, (x, y) in enumerate(points, start=1):
                tk.setcurvevalue(ph, curve, k, x, y * s)
        for link, power in self._pump_powers.items():
            tk.setlinkvalue(ph, link, en.PUMP_POWER, power * s)

    # -- demand --------------------------------------------------------------------------------------

    def _draw(self, options: Mapping[str, Any]) -> tuple[np.ndarray, str]:
        unknown = sorted(set(options) - set(OPTIONS))
        if unknown:
            raise ValueError(f"unknown reset options {unknown}; expected some of {list(OPTIONS)}")
        prof, d = self.profiles, self.config.demand
        rng: Any = self._legacy_rng if self._upstream else self.np_random
        draw = rng.randint if self._upstream else rng.integers
        if options.get("pattern") is not None:
            pattern = np.asarray(options["pattern"], dtype=np.float64)
            if pattern.ndim != 1 or not len(pattern) or not np.isfinite(pattern).all():
                raise ValueError("`pattern` must be a non-empty 1-D sequence of finite multipliers")
            if pattern.min() < prof.low or pattern.max() > prof.high:
                msg = (
                    f"`pattern` values must lie in [{prof.low:.6g}, {prof.high:.6g}] (the range of the packaged "
                    "profiles, which bounds the observation's demand estimate)"
                )
                raise ValueError(msg)
            return pattern, "custom"
        if options.get("profile_index") is not None:
            k = options["profile_index"]
            n = prof.test.shape[1]
            if isinstance(k, bool) or not isinstance(k, int | np.integer) or not 0 <= k < n:
                raise ValueError(f"`profile_index` must be an int in [0, {n}), not {k!r}")
            return prof.test[:, int(k)], f"test/{int(k)}"
        if options.get("is_evaluation") or d.split == "test":
            k = int(d.test_indices[0] + draw(d.test_indices[1] - d.test_indices[0]))
            return prof.test[:, k], f"test/{k}"
        probs = d.event_probs
        bucket = demand.BUCKETS[int(rng.choice(3, p=[probs.normal, probs.stressful, probs.extreme]))]
        files = prof.buckets[bucket]
        name = files[int(draw(len(files)))]
        column = int(draw(prof.train[name].shape[1]))  # by position in the file, as the reference
        week = prof.train_weeks[name][column]
        return prof.train[name][:, column], f"train/{bucket}/{Path(name).stem}/{week}"

    # -- gymnasium API -----------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Draw a demand profile and restart the hydraulics at t = 0."""
        super().reset(seed=seed)
        self._require_open()
        if self._upstream and seed is not None:
            self._legacy_rng = np.random.RandomState(seed)
        pattern, self._profile = self._draw(options or {})
        pattern = pattern * self._scales["demand"]
        self._pattern = pattern
        self._engine.set_pattern(self._pattern_index, pattern)
        cfg = self.config
        if self._estimate is None or self._per_episode_estimate:
            est = demand.moving_average if cfg.demand.estimate == "sma" else demand.exp_moving_average
            self._estimate = est(pattern, cfg.demand.window)
        self._m_ref = float(pattern[(cfg.duration // cfg.pattern_step) % len(pattern)])
        if self._tanks_moved:  # a snapped tank level also replaced its initial level (see _setup)
            tk, ph = self._engine.tk, self._engine.ph
            for node, level in zip(self._tank_nodes, self.network.tank_initial_level, strict=True):
                tk.setnodevalue(ph, node, en.TANKLEVEL, float(level))
            self._tanks_moved = False
        self._apply_pump_scale()
        self._engine.init_hydraulics()
        self._t = 0
        self._done = False
        self._statuses = self.network.pump_initial_status
        self._solved_at: int | None = None  # time of the last solve if nothing changed since
        tank_pos = self.network.tank_pos
        if self._zero_reset:  # the reference's reset observation; the true levels are kept for the dynamics
            self._levels = self._engine.node_values(en.PRESSURE)[tank_pos].copy()
            obs = self._observation(np.zeros(self._n_tanks), np.zeros(self._n_obs_junctions))
        else:
            self._solve()
            self._solved_at = 0
            self._read_statuses()
            press = self._engine.node_values(en.PRESSURE)
            self._levels = press[tank_pos].copy()
            obs = self._observation(self._levels, press[self._obs_junction_pos])
        info = self._info(0.0, 0.0, (0.0, 0.0, 0.0), 0)
        return obs, info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Set the pumps, advance the hydraulics one decision interval (or one EPANET event upstream)."""
        a = self._action(action)
        if self._done:
            raise RuntimeError("the episode has ended: call `reset()` before `step()`")
        self._apply(a)
        if self._fixed:
            dsr, ovf, volumes, n, halted = self._advance_interval()
            truncated = halted or self._t >= self.config.duration
        else:
            dsr, ovf, volumes, dt = self._advance_event()
            n, truncated = 1, dt == 0
        self._done = truncated
        rc = self.config.reward
        components = {"dsr": rc.dsr_coeff * dsr, "overflow": -rc.overflow_coeff * ovf}
        reward = components["dsr"] + components["overflow"]
        info = self._info(dsr, ovf, volumes, n, components)
        if self._fixed and halted:
            info["halted"] = True
        return self._obs, float(reward), False, truncated, info

    # -- dynamics ----------------------------------------------------------------------------------

    def _apply(self, a: int) -> None:
        if not self._agent_pumps:  # EPANET's controls switch the pumps
            return
        self._solved_at = None
        tk, ph, p = self._engine.tk, self._engine.ph, self._n_pumps
        statuses = tuple((a >> (p - 1 - i)) & 1 for i in range(p))
        for link, s in zip(self.network.pump_index, statuses, strict=True):
            tk.setlinkvalue(ph, link, en.STATUS, s)
        self._statuses = statuses

    def _solve(self) -> None:
        """``runH``; with exact tank events, snap tanks EPANET would fill or drain in under 0.5 s, re-solve."""
        self._engine.run()
        if self._exact_events and self._snap_tanks():
            self._engine.run()

    def _read_statuses(self) -> None:
        """With ``pump_control="controls"``: the statuses EPANET's controls set for the period solved last."""
        if not self._agent_pumps:
            tk, ph = self._engine.tk, self._engine.ph
            self._statuses = tuple(int(tk.getlinkvalue(ph, k, en.SETTING) > 0) for k in self.network.pump_index)

    def _snap_tanks(self) -> bool:
        tk, ph, net = self._engine.tk, self._engine.ph, self.network
        inflow = self._engine.node_values(en.DEMAND)
        snapped = False
        for k, node in enumerate(self._tank_nodes):
            q = float(inflow[node - 1])
            if q == 0.0:
                continue
            volume = tk.getnodevalue(ph, node, en.TANKVOLUME)
            room = tk.getnodevalue(ph, node, en.MAXVOLUME) - volume if q > 0 else volume - net.tank_min_volume[k]
            # EPANET rounds the time to fill or drain to whole seconds: below 0.5 s it ignores the event.
            if 0.0 < room < 0.5 * abs(q) * self._q_to_volume:
                # exactly at the limit: EPANET closes a tank's links only when its head reaches it
                level = net.tank_max_level[k] if q > 0 else net.tank_min_level[k]
                try:
                    tk.setnodevalue(ph, node, en.TANKLEVEL, float(level))
                except Exception:
                    continue
                snapped = True
        self._tanks_moved |= snapped
        return snapped

    def _dsr(self, delivered: float, full: float) -> float:
        if self._first_hour:  # the reference: hour-0 demand, 0 if not positive, no lower clip
            denom = self._m_ref * float(self.network.base_demand.sum())
            return min(1.0, delivered / denom) if denom > 0 else 0.0
        if full <= 0:
            return 1.0
        return min(1.0, max(0.0, delivered / full))

    def _pump_flow(self) -> float:
        tk, ph = self._engine.tk, self._engine.ph
        return float(sum(tk.getlinkvalue(ph, k, en.FLOW) for k in self.network.pump_index))

    def _demands(self) -> tuple[float, float]:
        """Delivered and requested demand of the junctions, each sum correctly rounded (``math.fsum``).

        Correct rounding makes the sums the same on every CPU; a BLAS dot product (``@``) adds in the order
        of the kernels it picks for the CPU, and its last bit moved the DSR of a test episode under AVX2 kernels.
        """
        eng, junctions = self._engine, self._junctions
        if self._first_hour:
            delivered = math.fsum(eng.node_values(en.DEMAND)[junctions])
            return delivered, delivered
        return (
            math.fsum(eng.node_values(en.DEMANDFLOW)[junctions]),
            math.fsum(eng.node_values(en.FULLDEMAND)[junctions]),
        )

    def _ovf_integral(self, a: np.ndarray, b: np.ndarray, dt: float) -> float:
        """Integral over dt of OVF along levels moving linearly from a to b."""
        total = 0.0
        for lo, hi, c, s in zip(np.minimum(a, b), np.maximum(a, b), self._ovf_start, self._ovf_scale, strict=True):
            if hi <= c:
                continue
            if lo >= c:
                total += dt * ((lo + hi) / 2 - c) / s
            else:
                total += dt * (hi - c) ** 2 / (2 * (hi - lo)) / s
        return total

    def _advance_interval(self) -> tuple[float, float, tuple[float, float, float], int, bool]:
        eng, tank_pos = self._engine, self.network.tank_pos
        t_end = self._t + self.config.decision_interval
        t = self._t
        levels = self._levels
        acc_dsr = acc_ovf = pumped = delivered_v = requested_v = 0.0
        n, halted = 0, False
        while t < t_end:
            if n or self._solved_at != t:  # else the state at t is solved and unchanged (one solve, as EPANET)
                self._solve()
            if n == 0:
                self._read_statuses()
            delivered, full = self._demands()
            q = self._pump_flow()
            dt = eng.next()
            if dt <= 0:  # EPANET stopped early (an unbalanced solve with "Unbalanced STOP")
                halted = True
                break
            after = eng.node_values(en.PRESSURE)[tank_pos]
            acc_dsr += dt * self._dsr(delivered, full)
            acc_ovf += self._ovf_integral(levels, after, dt)
            hours = dt / 3600.0 * self._flow_to_m3h
            pumped += q * hours
            delivered_v += delivered * hours
            requested_v += full * hours
            levels, t, n = after, t + dt, n + 1
        if not halted and t != t_end:
            raise en.EpanetError(f"EPANET stepped to t = {t} s past the decision time {t_end} s")
        self._t = t
        interval = float(self.config.decision_interval)
        if halted:
            self._levels = np.array(levels)
            self._observation(self._levels, self._obs[self._n_tanks : self._n_tanks + self._n_obs_junctions])
        else:
            self._solve()  # the state the agent sees: solved at the end of the interval
            self._solved_at = t
            press = eng.node_values(en.PRESSURE)
            self._levels = press[tank_pos].copy()
            self._observation(self._levels, press[self._obs_junction_pos])
        return acc_dsr / interval, acc_ovf / interval, (pumped, delivered_v, requested_v), n, halted

    def _advance_event(self) -> tuple[float, float, tuple[float, float, float], int]:
        eng = self._engine
        self._solve()
        self._read_statuses()
        q = self._pump_flow()
        dt = eng.next()
        # After nextH the tanks hold their levels at t + dt and the junctions their pressures at t.
        press = eng.node_values(en.PRESSURE)
        delivered, full = self._demands()
        self._levels = press[self.network.tank_pos].copy()
        dsr = self._dsr(delivered, full)
        ovf = float((np.maximum(self._levels - self._ovf_start, 0.0) / self._ovf_scale).sum())
        self._t += dt
        self._observation(self._levels, press[self._obs_junction_pos])
        hours = dt / 3600.0 * self._flow_to_m3h
        return dsr, ovf, (q * hours, delivered * hours, full * hours), dt

    def _observation(self, levels: np.ndarray, pressures: np.ndarray) -> np.ndarray:
        n_t = self._n_tanks
        obs = np.empty(n_t + self._n_obs_junctions + 3)
        obs[:n_t] = levels
        obs[n_t:-3] = pressures
        assert self._estimate is not None
        t = self._t
        obs[-3] = self._estimate[(t // self.config.pattern_step) % len(self._estimate)]
        phase = 2.0 * math.pi * (t % DAY) / DAY
        obs[-2] = math.sin(phase)
        obs[-1] = math.cos(phase)
        np.clip(obs, self._low, self._high, out=obs)
        self._obs: np.ndarray = obs.astype(np.float32)
        return self._obs

    def _info(
        self,
        dsr: float,
        ovf: float,
        volumes: tuple[float, float, float],
        substeps: int,
        components: dict[str, float] | None = None,
    ) -> dict[str, Any]:
        net = self.network
        return {
            "time": int(self._t),
            "dsr": float(dsr),
            "overflow": float(ovf),
            "reward_components": components or {"dsr": 0.0, "overflow": 0.0},
            "cost": float(ovf),
            "pumps": dict(zip(net.pump_ids, self._statuses, strict=True)),
            "tanks": dict(zip(net.tank_ids, (float(x) for x in self._levels), strict=True)),
            "volumes": {"pumped": volumes[0], "delivered": volumes[1], "requested": volumes[2]},
            "substeps": substeps,
            "profile": self._profile,
            "engine": self.engine_label,
        }

    # -- life cycle --------------------------------------------------------------------------------

    def _require_open(self) -> None:
        if self._engine.ph is None:
            raise RuntimeError("this WDSEnv is closed; create a new one")

    def render(self) -> str | np.ndarray | None:
        """``ansi``: one line with time, pumps and tank levels. ``rgb_array``: tank gauges over pump lamps."""
        if self.render_mode == "ansi":
            net = self.network
            pumps = " ".join(f"{p}={'on' if s else 'off'}" for p, s in zip(net.pump_ids, self._statuses, strict=True))
            tanks = " ".join(f"{t}={x:.2f}m" for t, x in zip(net.tank_ids, self._levels, strict=True))
            return f"t={self._t / 3600:7.2f}h  {pumps}  {tanks}\n"
        if self.render_mode == "rgb_array":
            return self._draw_frame()
        return None

    def _draw_frame(self, height: int = 96, width: int = 24) -> np.ndarray:
        net = self.network
        n = max(len(net.tank_ids), self._n_pumps)
        frame = np.full((height + width, n * width, 3), 255, dtype=np.uint8)
        span = np.maximum(net.tank_max_level - net.tank_min_level, 1e-9)
        fill = np.clip((self._levels - net.tank_min_level) / span, 0.0, 1.0)
        threshold = 1.0 - (self._lambda * net.tank_max_level - net.tank_min_level) / span
        for i, f in enumerate(fill):
            x = slice(i * width + 3, (i + 1) * width - 3)
            frame[:height, x] = (220, 220, 220)
            frame[height - int(f * height + 0.5) : height, x] = (40, 110, 220)
            frame[int(np.clip(threshold[i], 0, 1) * (height - 1)), x] = (220, 40, 40)  # overflow threshold
        for i, s in enumerate(self._statuses):
            frame[height + 4 : height + width - 4, i * width + 4 : (i + 1) * width - 4] = (
                (40, 170, 60) if s else (90, 90, 90)
            )
        return frame

    def close(self) -> None:
        """Release the EPANET project (also done when the env is garbage-collected)."""
        finalizer = getattr(self, "_finalizer", None)
        if finalizer is not None:
            finalizer()
        super().close()
