"""A native batched MicrogridEnv: N copies stepped together with numpy (corrected dynamics only).

The battery twin (:class:`~gym4real.microgrid.battery.BatteryTwin` with every correction on), its Bolun
aging and the streaming rainflow counter are rewritten over arrays of copies with the same arithmetic, in
the same order, as the scalar code; only ``exp`` and ``pow`` (numpy's against the C library's) may differ in
the last bit, which moves the state of health by about 1e-16.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from gym4real.core.actions import box_actions
from gym4real.core.vector import check_max_episode_steps, copy_generators, with_masks
from gym4real.microgrid.aging import AgingParams
from gym4real.microgrid.battery import KELVIN, BatteryParams
from gym4real.microgrid.config import MicrogridConfig
from gym4real.microgrid.env import (
    ACTION_TOLERANCE,
    ACTIONS,
    SECONDS_PER_DAY,
    SECONDS_PER_YEAR,
    TWIN_FIXES,
    TWO_PI,
    MicrogridEnv,
)

Array = np.ndarray


def _cycle_damage(p: AgingParams, dod: Array, mean_soc: Array, mean_temp: Array) -> Array:
    """Damage of half cycles (:meth:`AgingParams.cycle_damage` with ``count = 0.5``) over arrays."""
    value: Array = np.full(dod.shape, 0.5)
    for factor in p.cyclic:
        if factor == "dod_bolun":
            safe = np.where(dod > 0.0, dod, 1.0)
            value = value * np.where(dod > 0.0, 1.0 / (p.k_delta1 * safe**p.k_delta2 + p.k_delta3), 0.0)
        elif factor == "soc":
            value = value * np.exp(p.k_soc * (mean_soc - p.soc_ref))
        else:
            value = value * np.exp(p.k_temp * (mean_temp - p.temp_ref) * p.temp_ref / mean_temp)
    return value


class _Rainflow:
    """:class:`~gym4real.microgrid.rainflow.StreamingRainflow` for N series at once.

    Each copy's residue stack is a row of padded arrays (SoC, point index, cumulative temperature before
    the index, half damage of the pair ending there) grown on demand; the cycle extraction loops while
    some copy can still close a cycle (a few passes per point).
    """

    def __init__(self, n: int, params: AgingParams, depth: int = 32) -> None:
        self.params = params
        self.depth = 0
        self.size = np.zeros(n, dtype=np.int64)
        self.stack = np.zeros((4, n, 0))  # x, index, cumulative temperature, half damage
        self._grow(n, depth)
        self.count = np.zeros(n)
        self.cum_temp = np.zeros(n)
        self.direction = np.zeros(n)
        self.last = np.zeros((3, n))  # x, index, cumulative temperature of the latest point
        self.closed = np.zeros(n)
        self.residue = np.zeros(n)
        self.tail = np.zeros(n)

    def _grow(self, n: int, depth: int) -> None:
        stack = np.zeros((4, n, depth))
        stack[:, :, : self.depth] = self.stack
        self.stack, self.depth = stack, depth

    def reset(self, idx: Array, x: Array, temp: Array) -> None:
        """Restart the counters ``idx`` with a first point ``(x, temp)``."""
        self.size[idx] = 0
        self.count[idx] = 1.0
        self.cum_temp[idx] = temp
        self.direction[idx] = 0.0
        self.last[0, idx] = x
        self.last[1:, idx] = 0.0
        self.closed[idx] = self.residue[idx] = self.tail[idx] = 0.0

    @property
    def total(self) -> Array:
        """Closed cycles plus the residue's half cycles, per copy."""
        return self.closed + self.residue + self.tail

    def _half(self, a: Array, b: Array) -> Array:
        """Damage of the half cycles between points ``a`` and ``b`` (rows x, index, cumulative temperature)."""
        temp = (b[2] - a[2]) / (b[1] - a[1])  # stacked points have increasing indices: the span is > 0
        return _cycle_damage(self.params, np.abs(b[0] - a[0]), 0.5 * (a[0] + b[0]), temp)

    def push(self, x: Array, temp: Array) -> None:
        """Add the next point of every series."""
        point = np.stack([x, self.count, self.cum_temp])
        self.count += 1.0
        self.cum_temp = self.cum_temp + temp
        d = x - self.last[0]
        moving = d != 0.0  # flat: not a peak or valley, only the temperature sums move on
        reversal = moving & ((self.size == 0) | (d * self.direction < 0.0))
        if reversal.any():
            self._push_reversal(np.flatnonzero(reversal))
        idx = np.flatnonzero(moving)
        self.direction[idx] = d[idx]
        self.last[:, idx] = point[:, idx]
        top = self.stack[:3, idx, self.size[idx] - 1]
        self.tail[idx] = self._half(top, point[:, idx])

    def _push_reversal(self, idx: Array) -> None:
        """Push the latest point of the copies ``idx`` as a reversal and extract the cycles it closes."""
        size, stack = self.size[idx], self.stack
        if size.max() + 1 > self.depth:
            self._grow(len(self.size), 2 * self.depth)
            stack = self.stack
        p = self.last[:, idx]
        half = np.zeros(len(idx))
        below = size > 0
        if below.any():
            j = idx[below]
            half[below] = self._half(stack[:3, j, size[below] - 1], p[:, below])
            self.residue[j] += half[below]
        stack[:3, idx, size] = p
        stack[3, idx, size] = half
        self.size[idx] = size + 1
        live = idx[self.size[idx] >= 3]
        while live.size:
            n = self.size[live]
            c, b, a = stack[0, live, n - 1], stack[0, live, n - 2], stack[0, live, n - 3]
            closes = ~(np.abs(c - b) < np.abs(b - a))
            live, n = live[closes], n[closes]
            first = n == 3
            t = live[first]  # the cycle holds the starting point: a half cycle, the first point dropped
            if t.size:
                bh = stack[3, t, 1]
                self.closed[t] += bh
                self.residue[t] -= bh
                stack[:, t, 0] = stack[:, t, 1]
                stack[3, t, 0] = 0.0
                stack[:, t, 1] = stack[:, t, 2]
                self.size[t] = 2
            m, k = live[~first], n[~first]  # a full cycle: its two points dropped
            if m.size:
                ah, bh, ch = stack[3, m, k - 3], stack[3, m, k - 2], stack[3, m, k - 1]
                self.closed[m] += 2.0 * bh
                self.residue[m] -= bh + ch + ah
                c_point = stack[:3, m, k - 1]
                hc = self._half(stack[:3, m, k - 4], c_point)
                stack[:3, m, k - 3] = c_point
                stack[3, m, k - 3] = hc
                self.residue[m] += hc
                self.size[m] = k - 2
            live = live[self.size[live] >= 3]


class _Twin:
    """:class:`~gym4real.microgrid.battery.BatteryTwin` (every correction on) and its aging for N batteries."""

    def __init__(self, n: int, params: BatteryParams, eol_soh: float) -> None:
        self.params = p = params
        self.eol_soh = eol_soh
        grid = p.grid
        self._temps, self._socs = np.array(grid.temps), np.array(grid.socs)
        self._values = np.array(grid.values)  # (parameter, temperature, soc)
        self._dvdt_x, self._dvdt_y = np.array(p.dvdt_socs), np.array(p.dvdt_values)
        self._r_tot = p.r_cond + p.r_conv
        self.aging = a = p.aging
        self._timed = "time" in a.calendar
        self.rainflow = _Rainflow(n, a)
        zeros = np.zeros(n)
        self.soc, self.soh, self.soh0 = zeros.copy(), zeros.copy(), zeros.copy()
        self.temperature, self.v_rc, self.capacity = zeros.copy(), zeros.copy(), zeros.copy()
        self.calendar, self.damage, self.deg = zeros.copy(), zeros.copy(), zeros.copy()
        self.violation = zeros.copy()

    def reset(self, idx: Array, soc: Array, soh: Array, temperature: Array) -> None:
        """Put the batteries ``idx`` at rest (as :meth:`BatteryTwin.reset`)."""
        self.soc[idx], self.soh[idx], self.soh0[idx] = soc, soh, soh
        self.temperature[idx] = temperature
        self.capacity[idx] = self.params.nominal_capacity * soh
        self.v_rc[idx] = 0.0
        self.calendar[idx] = self.damage[idx] = self.deg[idx] = 0.0
        self.rainflow.reset(idx, soc, temperature)

    def _lookup(self, temp_c: Array, soc: Array) -> Array:
        """R0, R1, C and OCV (rows) by bilinear interpolation, clamped at the grid's edges."""
        ts, ss, v = self._temps, self._socs, self._values
        i = np.clip(np.searchsorted(ts, temp_c, side="right") - 1, 0, len(ts) - 2)
        wt = np.where(temp_c <= ts[0], 0.0, np.where(temp_c >= ts[-1], 1.0, (temp_c - ts[i]) / (ts[i + 1] - ts[i])))
        j = np.clip(np.searchsorted(ss, soc, side="right") - 1, 0, len(ss) - 2)
        ws = np.where(soc <= ss[0], 0.0, np.where(soc >= ss[-1], 1.0, (soc - ss[j]) / (ss[j + 1] - ss[j])))
        w11 = wt * ws
        w10 = wt - w11
        w01 = ws - w11
        w00 = 1.0 - wt - w01
        return w00 * v[:, i, j] + w01 * v[:, i, j + 1] + w10 * v[:, i + 1, j] + w11 * v[:, i + 1, j + 1]

    def _dvdt(self, soc: Array) -> Array:
        xs, ys = self._dvdt_x, self._dvdt_y
        j = np.searchsorted(xs[1 : len(xs) - 1], soc, side="left")
        return ys[j] + (ys[j + 1] - ys[j]) * (soc - xs[j]) / (xs[j + 1] - xs[j])

    def step(self, power: Array, dt: float, t_amb: Array) -> Array:
        """Apply ``power`` W (clipped to the feasible range) for ``dt`` s; return the applied power."""
        p = self.params
        soc0, temp0 = self.soc, self.temperature
        charge = self.capacity * 3600.0 / dt
        # 1. parameters at the state at the start of the step
        r0, r1, c, ocv = self._lookup(temp0 - KELVIN, soc0)
        den = 1.0 / dt + 1.0 / (r1 * c)
        a = ocv - self.v_rc / dt / den
        b = r0 + 1.0 / c / den
        # 2. feasible range: SoC window, the pack's current and power bounds
        lo_i = np.maximum((p.soc_min - soc0) * charge, p.current_min)
        hi_i = np.minimum((p.soc_max - soc0) * charge, p.current_max)
        lo_i, hi_i = np.minimum(lo_i, 0.0), np.maximum(hi_i, 0.0)
        lo_i = np.maximum(lo_i, -a / (2.0 * b))
        lo = np.maximum((a + b * lo_i) * lo_i, p.power_min)
        hi = np.minimum((a + b * hi_i) * hi_i, p.power_max)
        applied = np.where(power < lo, lo, np.where(power > hi, hi, power))
        clipped = applied != power
        self.violation = np.zeros(len(power))
        if clipped.any():
            w, pw = np.flatnonzero(clipped), power[clipped]
            aw, bw = a[w], b[w]
            disc = aw * aw + 4.0 * bw * pw
            root = np.sqrt(np.maximum(disc, 0.0))
            i_req = np.where(disc > 0.0, 2.0 * pw / (aw + root), -aw / (2.0 * bw))
            soc_req = soc0[w] + i_req / charge[w]
            self.violation[w] = np.maximum(np.maximum(soc_req - p.soc_max, p.soc_min - soc_req), 0.0)
        # 3. electrical: the current solves V(I) I = P with the new terminal voltage
        root = np.sqrt(np.maximum(a * a + 4.0 * b * applied, 0.0))
        current = np.where(applied != 0.0, 2.0 * applied / (a + root), 0.0)
        v_rc = (self.v_rc / dt - current / c) / den
        i_r1 = v_rc / r1
        # 4. state of charge (coulomb counting against SoH * nominal capacity)
        soc = np.clip(soc0 + current / charge, 0.0, 1.0)
        # 5. thermal (core temperature as the state, dV/dT at the new SoC)
        heat = r0 * current * current + r1 * i_r1 * i_r1
        cth = p.c_thermal / dt
        r_tot = self._r_tot
        core = (cth * temp0 + t_amb / r_tot + heat) / (cth + 1.0 / r_tot - self._dvdt(soc) * current)
        # 6. aging: calendar integrated over the step, streaming rainflow, monotone degradation
        ag = self.aging
        if self._timed:
            stress: Array | float = 1.0
            if "soc" in ag.calendar:
                stress = stress * np.exp(ag.k_soc * (0.5 * (soc0 + soc) - ag.soc_ref))
            if "temperature" in ag.calendar:
                mean_t = 0.5 * (temp0 + core)
                stress = stress * np.exp(ag.k_temp * (mean_t - ag.temp_ref) * ag.temp_ref / mean_t)
            self.calendar = self.calendar + ag.k_t * dt * stress
        self.rainflow.push(soc, core)
        f_d = self.calendar + self.rainflow.total
        worse = f_d > self.damage
        self.damage = np.where(worse, f_d, self.damage)
        alpha = ag.alpha_sei
        deg = 1.0 - alpha * np.exp(-ag.beta_sei * f_d) - (1.0 - alpha) * np.exp(-f_d)
        self.deg = np.where(worse, deg, self.deg)
        self.soh = self.soh0 - self.deg
        self.capacity = p.nominal_capacity * self.soh
        self.soc, self.temperature, self.v_rc = soc, core, v_rc
        return applied


class MicrogridVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """``num_envs`` copies of :class:`~gym4real.microgrid.env.MicrogridEnv` in arrays, same dynamics step by step.

    ## Description
    The equivalent circuit, the thermal model, the calendar aging, the streaming rainflow counter and the
    reward of every copy are computed together with numpy (no per-copy Python in a step, except at the
    resets that draw each copy's episode). Only the default ``fidelity="corrected"`` with every fix on is
    batched; other settings raise ``ValueError`` (use ``gymnasium.vector.SyncVectorEnv``). The copies run
    the nominal model: the perturbation hook (:meth:`MicrogridEnv.perturb`) is not batched.

    ## Spaces
    ``action_space``: ``Box(0, 1, (num_envs, 1), float32)``; an array of shape ``(num_envs,)`` is accepted
    too. Every action is checked as the single env does (NaN or outside ``[0, 1]`` beyond 1e-6 raises
    :class:`~gym4real.core.errors.ActionError`, naming the copies). ``observation_space``: the single env's
    observation batched, ``(num_envs, 10)`` (11 with ``observe_soh``).

    ## Seeding and episodes
    Copy ``i`` of ``reset(seed=s)`` is the single env reset with seed ``s + i``; each copy keeps its own
    generator (or, with ``profile_order: sequential``, its position in the profile list), so a later
    ``reset()`` or autoreset draws what that single env would draw. Copies end independently (end of life,
    ``max_steps``, end of data); the step after a copy ends resets it (Gymnasium's next-step autoreset:
    reset observation, zero reward, its action ignored).

    ## Info
    ``reward_components`` and ``pure_components`` (arrays of ``trading``, ``degradation``, ``clipping``),
    ``cost``, ``soc``, ``soh``, ``temperature`` and ``energy`` (``demand``, ``pv``, ``to_battery``,
    ``from_battery``, ``sold``, ``bought``), one value per copy; ``reset`` gives ``profile``, ``start``,
    ``soc`` and ``soh``.

    ## Arguments
    ``gymnasium.make_vec("gym4real/microgrid-v0", num_envs=N, vectorization_mode="vector_entry_point",
    **kwargs)`` or ``MicrogridVectorEnv(N, config=None, preset=None, max_episode_steps=None, **overrides)``,
    with the single env's configuration arguments; ``max_episode_steps`` truncates a copy after that many
    decisions, as Gymnasium's ``TimeLimit`` does to the single env.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        config: MicrogridConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        max_episode_steps: int | None = None,
        **overrides: Any,
    ) -> None:
        self.single = s = MicrogridEnv(config, preset=preset, **overrides)
        self.max_episode_steps = check_max_episode_steps(max_episode_steps)
        self.config = cfg = s.config
        if cfg.fidelity != "corrected":
            msg = (
                'MicrogridVectorEnv batches fidelity="corrected" only; for fidelity="upstream" use '
                "gymnasium.make_vec(..., vectorization_mode='sync')"
            )
            raise ValueError(msg)
        off = [f for f in (*TWIN_FIXES, "data_alignment") if not cfg.fix(f)]
        if off:
            msg = (
                f"MicrogridVectorEnv batches the corrected dynamics with every fix on; {off} are off: "
                "use gymnasium.make_vec(..., vectorization_mode='sync')"
            )
            raise ValueError(msg)
        self.num_envs = n = num_envs
        self.render_mode = None
        self.single_observation_space = s.observation_space
        self.single_action_space = s.action_space
        self.observation_space = batch_space(s.observation_space, n)
        self.action_space = batch_space(s.action_space, n)
        w = s.world
        self._labels = np.array(w.labels)
        self._demand = np.asarray(w.demand)
        self._pv, self._ask, self._bid = np.array(s._pv), np.array(s._ask), np.array(s._bid)
        self._temp_amb = np.array(w.temp)
        self._exogenous = self._exogenous_table()
        self.twin = _Twin(n, s.battery_params, cfg.battery.eol_soh)
        self._soh_obs = 3 if cfg.observe_soh else None
        self._rngs: list[np.random.Generator] | None = None
        self._cursor = np.zeros(n, dtype=np.int64)
        self._row = np.ones(n, dtype=np.int64)
        self._iterations = np.zeros(n, dtype=np.int64)
        self._elapsed = np.zeros(n, dtype=np.int64)  # decisions since the copy's reset
        self._limit = np.ones(n, dtype=np.int64)
        self._col = np.zeros(n, dtype=np.int64)
        self._autoreset = np.zeros(n, dtype=bool)

    def _exogenous_table(self) -> Array:
        """Per data row: PV of the hour elapsed, ask and bid of the upcoming hour, time angles (as the single env)."""
        s = self.single
        rows = range(s._n_rows + 1)
        table = []
        for row in rows:
            now, prev = row % s._hour_mod, (row - 1) % s._hour_mod
            tau = row * s._step_s
            year, day = TWO_PI * tau / SECONDS_PER_YEAR, TWO_PI * tau / SECONDS_PER_DAY
            table.append(
                [s._pv[prev], s._ask[now], s._bid[now], math.sin(year), math.cos(year), math.sin(day), math.cos(day)]
            )
        return np.array(table)

    # -- episodes ------------------------------------------------------------------------------------

    def _draw(self, i: int, options: Mapping[str, Any]) -> tuple[int, int, float, float, float]:
        """Copy ``i``'s profile column, start row, SoC, SoH and temperature, drawn as the single env does."""
        s, p = self.single, self.single.battery_params
        assert self._rngs is not None  # reset() seeds the generators before any draw
        profile, row, next_cursor, battery = s.draw_start(options, self._rngs[i], int(self._cursor[i]))
        if next_cursor is not None:
            self._cursor[i] = next_cursor
        if battery is None:
            battery = (p.init_soc, p.init_soh, s.world.temp[s._day(row * s._step_s)])
        return s.world.labels.index(profile), row, *battery

    def _start(self, idx: Array, options: Mapping[str, Any]) -> None:
        """Start a new episode in the copies ``idx``."""
        draws = np.array([self._draw(int(i), options) for i in idx]).T
        col, row = draws[0].astype(np.int64), draws[1].astype(np.int64)
        self._col[idx], self._row[idx], self._iterations[idx], self._elapsed[idx] = col, row, 0, 0
        max_steps = self.config.max_steps or self.single._n_rows
        self._limit[idx] = np.minimum(self.single._n_rows - row, max_steps)
        self.twin.reset(idx, draws[2], draws[3], draws[4])

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode in every copy; with a seed, copy ``i`` as the single env with ``seed + i``.

        Args:
            seed: Seed of copy 0 (copy ``i`` gets ``seed + i``); None continues each copy's generator.
            options: The single env's reset options (``profile``, ``start``), applied to every copy.

        Returns:
            The batched observation and ``info`` with each copy's ``profile``, ``start``, ``soc`` and ``soh``.
        """
        super().reset(seed=seed)
        n = self.num_envs
        self._rngs = copy_generators(self, self._rngs, seed)
        if seed is not None:
            self._cursor = (seed + np.arange(n)) % len(self.single.profiles)
        idx = np.arange(n)
        self._start(idx, options or {})
        self._autoreset[:] = False
        return self._obs(), with_masks(self._reset_info(idx), n)

    def _reset_info(self, idx: Array) -> dict[str, Any]:
        t = self.twin
        return {
            "profile": self._labels[self._col[idx]],
            "start": self._row[idx].copy(),
            "soc": t.soc[idx].copy(),
            "soh": t.soh[idx].copy(),
        }

    # -- observation ---------------------------------------------------------------------------------

    def _obs(self) -> Array:
        t, row = self.twin, self._row
        exo = self._exogenous[np.minimum(row, len(self._exogenous) - 1)]
        demand = self._demand[(row - 1) % len(self._demand), self._col]
        cols = [np.clip(t.temperature, 250.0, 400.0), t.soc, demand, exo[:, 0], exo[:, 1], exo[:, 2]]
        if self._soh_obs is not None:
            cols.insert(self._soh_obs, np.clip(t.soh, 0.0, 1.0))
        obs = np.empty((self.num_envs, len(cols) + 4), dtype=np.float32)
        for k, col in enumerate(cols):
            obs[:, k] = col
        obs[:, len(cols) :] = exo[:, 3:]
        return obs

    # -- dynamics ------------------------------------------------------------------------------------

    def _actions(self, actions: Any) -> Array:
        n = self.num_envs
        return box_actions(actions, self.single_action_space, n, ACTIONS, tolerance=ACTION_TOLERANCE).reshape(n)

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Route each copy's fraction of its net power to its battery for ``decision_interval`` hours.

        Args:
            actions: One fraction in ``[0, 1]`` per copy.

        Returns:
            Batched observation, reward, terminated, truncated and ``info`` (arrays, one value per copy).
        """
        a = self._actions(actions)
        n, s, t = self.num_envs, self.single, self.twin
        interval = self.config.decision_interval
        dt, hours, temp_step = s._step_s, s._hours_per_step, s.world.temp_step
        zeros = np.zeros(n)
        trading, degradation, clipping, cost = zeros.copy(), zeros.copy(), zeros.copy(), zeros.copy()
        energy = {k: zeros.copy() for k in ("demand", "pv", "to_battery", "from_battery", "sold", "bought")}
        active = np.ones(n, dtype=bool)
        terminated, truncated = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
        frozen: Array | None = None  # observation and state of the copies that ended inside the interval
        for _ in range(interval):
            r = self._row
            demand = self._demand[r % len(self._demand), self._col]
            t_amb = self._temp_amb[(r * dt // temp_step).astype(np.int64) % len(self._temp_amb)]
            gen = self._pv[r % s._hour_mod]
            margin = gen - demand
            request = margin * a
            soh0 = t.soh
            applied = t.step(request, dt, t_amb)
            traded = margin - applied
            now = r % s._hour_mod
            price = np.where(traded < 0.0, self._ask[now], self._bid[now])
            terms = {
                "trading": traded * price * hours,
                "degradation": (soh0 - t.soh) * s._deg_per_soh,
                "clipping": np.abs(request - applied) * hours,
                "cost": t.violation,
                "demand": demand * hours,
                "pv": gen * hours,
                "to_battery": np.where(applied > 0.0, applied * hours, 0.0),
                "from_battery": np.where(applied > 0.0, 0.0, applied * hours),
                "sold": np.where(traded < 0.0, 0.0, traded * hours),
                "bought": np.where(traded < 0.0, traded * hours, 0.0),
            }
            if interval > 1:
                terms = {k: np.where(active, v, 0.0) for k, v in terms.items()}
            trading += terms["trading"]
            degradation -= terms["degradation"]
            clipping -= terms["clipping"]
            cost += terms["cost"]
            for k in ("demand", "pv", "to_battery", "sold"):
                energy[k] += terms[k]
            for k in ("from_battery", "bought"):
                energy[k] -= terms[k]
            self._row = r + 1
            self._iterations += 1
            term = t.soh <= t.eol_soh
            trunc = self._iterations >= self._limit
            ended = active & (term | trunc)
            if ended.any():
                terminated |= ended & term
                truncated |= ended & trunc & ~term
                active &= ~ended
                if interval > 1:
                    now_state = np.column_stack([self._obs(), t.soc, t.soh, t.temperature])
                    frozen = now_state if frozen is None else np.where(ended[:, None], now_state, frozen)
                    if not active.any():
                        break
        obs = self._obs()
        soc, soh, temperature = t.soc.copy(), t.soh.copy(), t.temperature.copy()
        if frozen is not None:
            done = terminated | truncated
            obs[done] = frozen[done, :-3]
            soc[done], soh[done], temperature[done] = frozen[done, -3:].T

        wt, wd, wc = s._weights
        comps = {
            "trading": wt * trading * s._trading_scale,
            "degradation": wd * degradation,
            "clipping": wc * clipping * s._clipping_scale,
        }
        pure = {"trading": trading, "degradation": degradation, "clipping": clipping}
        self._elapsed += 1
        if self.max_episode_steps is not None:
            truncated |= self._elapsed >= self.max_episode_steps
        reset = self._autoreset
        if reset.any():  # these copies ended at the previous step: they start over, their action unused
            idx = np.flatnonzero(reset)
            self._start(idx, {})
            obs[idx] = self._obs()[idx]
            soc[idx], soh[idx], temperature[idx] = t.soc[idx], t.soh[idx], t.temperature[idx]
            terminated[idx] = truncated[idx] = False
            cost[idx] = 0.0
            for group in (comps, pure, energy):
                for v in group.values():
                    v[idx] = 0.0
        self._autoreset = terminated | truncated
        reward = comps["trading"] + comps["degradation"] + comps["clipping"]
        # the copies restarted now report these from their reset, as the single env's reset info has them
        info = with_masks(
            {"reward_components": comps, "pure_components": pure, "cost": cost, "soc": soc, "soh": soh}, n
        )
        info.update(with_masks({"temperature": temperature, "energy": energy}, n, present=~reset))  # only a step's
        return obs, reward, terminated, truncated, info
