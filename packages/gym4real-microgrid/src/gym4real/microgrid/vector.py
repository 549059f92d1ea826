"""A native batched MicrogridEnv: N copies stepped together (corrected dynamics only).

With numba (the extra ``fast``) each decision of every copy runs in one compiled loop
(:mod:`gym4real.microgrid.vector_kernel`): the single env's numbers, bit for bit. Without it, the battery
twin (:class:`~gym4real.microgrid.battery.BatteryTwin` with every correction on), its Bolun aging and the
streaming rainflow counter are rewritten over arrays of copies with the same arithmetic, in the same order,
as the scalar code; only ``exp`` and ``pow`` differ: numpy's vectorised ones round differently from the C
library's in the last bit for about 5 % of arguments, which moves the state of health by about 1e-16 and
the degradation reward (1e-16 times the EUR per unit of SoH) by about 1e-12.
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
from gym4real.core.vector import (
    check_max_episode_steps,
    compiled_kernel,
    copy_generators,
    scalar_exp,
    scalar_power,
    with_masks,
)
from gym4real.microgrid.aging import CYCLIC_FACTORS, AgingParams
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
# the rows of the batched twin's state (the compiled step's ``battery``)
STATE = ("soc", "soh", "soh0", "temperature", "v_rc", "capacity", "calendar", "damage", "degradation")
OBSERVED_STATE = [STATE.index(k) for k in ("soc", "soh", "temperature")]  # reported in info
# a decision's running sums of each copy, as the single env's step adds them up (the compiled step's ``sums``)
SUMS = ("trading", "degradation", "clipping", "cost", "demand", "pv", "to_battery", "from_battery", "sold", "bought")


def _cycle_damage(p: AgingParams, dod: Array, mean_soc: Array, mean_temp: Array) -> Array:
    """Damage of half cycles (:meth:`AgingParams.cycle_damage` with ``count = 0.5``) over arrays."""
    value: Array = np.full(dod.shape, 0.5)
    for factor in p.cyclic:
        if factor == "dod_bolun":
            safe = np.where(dod > 0.0, dod, 1.0)
            value = value * np.where(dod > 0.0, 1.0 / (p.k_delta1 * scalar_power(safe, p.k_delta2) + p.k_delta3), 0.0)
        elif factor == "soc":
            value = value * scalar_exp(p.k_soc * (mean_soc - p.soc_ref))
        else:
            value = value * scalar_exp(p.k_temp * (mean_temp - p.temp_ref) * (p.temp_ref / mean_temp))
    return value


class _Rainflow:
    """:class:`~gym4real.microgrid.rainflow.StreamingRainflow` for N series at once.

    Each copy's residue stack is ``stack[copy]``, its points (SoC, point index, cumulative temperature
    before the index, half damage of the pair ending there) padded to a depth grown on demand; the cycle
    extraction loops while some copy can still close a cycle (a few passes per point). The per-copy values
    are rows of ``walk`` (points so far, cumulative temperature, latest direction), ``last`` and ``damage``
    (closed, residue, tail), updated in place (the compiled step writes into them).
    """

    def __init__(self, n: int, params: AgingParams, depth: int = 32) -> None:
        self.params = params
        self.depth = 0
        self.size = np.zeros(n, dtype=np.int64)
        self.stack = np.zeros((n, 0, 4))  # x, index, cumulative temperature, half damage
        self._grow(n, depth)
        self.walk = np.zeros((3, n))
        self.count, self.cum_temp, self.direction = self.walk
        self.last = np.zeros((3, n))  # x, index, cumulative temperature of the latest point
        self.damage = np.zeros((3, n))
        self.closed, self.residue, self.tail = self.damage

    def reserve(self, points: int) -> None:
        """Make room in every stack for ``points`` more reversals."""
        need = int(self.size.max()) + points
        if need > self.depth:
            self._grow(len(self.size), max(need, 2 * self.depth))

    def _grow(self, n: int, depth: int) -> None:
        stack = np.zeros((n, depth, 4))
        stack[:, : self.depth] = self.stack
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
        self.cum_temp += temp
        d = x - self.last[0]
        moving = d != 0.0  # flat: not a peak or valley, only the temperature sums move on
        reversal = moving & ((self.size == 0) | (d * self.direction < 0.0))
        if reversal.any():
            self._push_reversal(np.flatnonzero(reversal))
        idx = np.flatnonzero(moving)
        self.direction[idx] = d[idx]
        self.last[:, idx] = point[:, idx]
        top = self.stack[idx, self.size[idx] - 1, :3].T
        self.tail[idx] = self._half(top, point[:, idx])

    def _push_reversal(self, idx: Array) -> None:
        """Push the latest point of the copies ``idx`` as a reversal and extract the cycles it closes."""
        self.reserve(1)
        size, stack = self.size[idx], self.stack
        p = self.last[:, idx]
        half = np.zeros(len(idx))
        below = size > 0
        if below.any():
            j = idx[below]
            half[below] = self._half(stack[j, size[below] - 1, :3].T, p[:, below])
            self.residue[j] += half[below]
        stack[idx, size, :3] = p.T
        stack[idx, size, 3] = half
        self.size[idx] = size + 1
        live = idx[self.size[idx] >= 3]
        while live.size:
            n = self.size[live]
            c, b, a = stack[live, n - 1, 0], stack[live, n - 2, 0], stack[live, n - 3, 0]
            closes = ~(np.abs(c - b) < np.abs(b - a))
            live, n = live[closes], n[closes]
            first = n == 3
            t = live[first]  # the cycle holds the starting point: a half cycle, the first point dropped
            if t.size:
                bh = stack[t, 1, 3]
                self.closed[t] += bh
                self.residue[t] -= bh
                stack[t, 0] = stack[t, 1]
                stack[t, 0, 3] = 0.0
                stack[t, 1] = stack[t, 2]
                self.size[t] = 2
            m, k = live[~first], n[~first]  # a full cycle: its two points dropped
            if m.size:
                ah, bh, ch = stack[m, k - 3, 3], stack[m, k - 2, 3], stack[m, k - 1, 3]
                self.closed[m] += 2.0 * bh
                self.residue[m] -= bh + ch + ah
                c_point = stack[m, k - 1, :3].T
                hc = self._half(stack[m, k - 4, :3].T, c_point)
                stack[m, k - 3, :3] = c_point.T
                stack[m, k - 3, 3] = hc
                self.residue[m] += hc
                self.size[m] = k - 2
            live = live[self.size[live] >= 3]


class _Twin:
    """:class:`~gym4real.microgrid.battery.BatteryTwin` (every correction on) and its aging for N batteries.

    The per-copy values are the rows of ``state`` (:data:`STATE`), updated in place (the compiled step
    writes into them).
    """

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
        self.state = np.zeros((len(STATE), n))
        self.soc, self.soh, self.soh0, self.temperature, self.v_rc, self.capacity = self.state[:6]
        self.calendar, self.damage, self.deg = self.state[6:]
        self.violation = np.zeros(n)

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
                stress = stress * scalar_exp(ag.k_soc * (0.5 * (soc0 + soc) - ag.soc_ref))
            if "temperature" in ag.calendar:
                mean_t = 0.5 * (temp0 + core)
                stress = stress * scalar_exp(ag.k_temp * (mean_t - ag.temp_ref) * (ag.temp_ref / mean_t))
            self.calendar += ag.k_t * dt * stress
        self.rainflow.push(soc, core)
        f_d = self.calendar + self.rainflow.total
        worse = f_d > self.damage
        np.copyto(self.damage, f_d, where=worse)
        alpha = ag.alpha_sei
        deg = 1.0 - alpha * scalar_exp(-ag.beta_sei * f_d) - (1.0 - alpha) * scalar_exp(-f_d)
        np.copyto(self.deg, deg, where=worse)
        np.subtract(self.soh0, self.deg, out=self.soh)
        np.multiply(p.nominal_capacity, self.soh, out=self.capacity)
        self.soc[:], self.temperature[:], self.v_rc[:] = soc, core, v_rc
        return applied


class MicrogridVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """``num_envs`` copies of :class:`~gym4real.microgrid.env.MicrogridEnv` in arrays, same dynamics step by step.

    ## Description
    The equivalent circuit, the thermal model, the calendar aging, the streaming rainflow counter and the
    reward of every copy are computed together (no per-copy Python in a step, except at the resets that
    draw each copy's episode): with numba installed (the extra ``fast``) in one compiled loop over the
    copies that evaluates the single env's expressions in its order (bit for bit its numbers);
    ``compiled=False`` uses numpy (see the module docstring for its last-bit differences), ``compiled=True``
    requires numba. Only the default ``fidelity="corrected"`` with every fix on is batched; other settings
    raise ``ValueError`` (use ``gymnasium.vector.SyncVectorEnv``). The copies run the nominal model: the
    perturbation hook (:meth:`MicrogridEnv.perturb`) is not batched.

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
    **kwargs)`` or ``MicrogridVectorEnv(N, config=None, preset=None, max_episode_steps=None, compiled=None,
    **overrides)``, with the single env's configuration arguments; ``max_episode_steps`` truncates a copy
    after that many decisions, as Gymnasium's ``TimeLimit`` does to the single env.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        config: MicrogridConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        max_episode_steps: int | None = None,
        compiled: bool | None = None,
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
        shape = self.observation_space.shape
        assert shape is not None  # a Box batched
        self._obs_shape = shape
        self.action_space = batch_space(s.action_space, n)
        w = s.world
        self._labels = np.array(w.labels)
        self._demand = np.ascontiguousarray(np.asarray(w.demand).T)  # (profile, row): a copy reads along a row
        self._pv, self._ask, self._bid = np.array(s._pv), np.array(s._ask), np.array(s._bid)
        self._temp_amb = np.array(w.temp)
        self._exogenous = self._exogenous_table()
        self.twin = _Twin(n, s.battery_params, cfg.battery.eol_soh)
        self._soh_obs = 3 if cfg.observe_soh else None
        self._rngs: list[np.random.Generator] | None = None
        self._cursor = np.zeros(n, dtype=np.int64)
        # data row, hours since the copy's reset, its episode's hours, its profile column (updated in place)
        self._clock = np.ones((4, n), dtype=np.int64)
        self._row, self._iterations, self._limit, self._col = self._clock
        self._elapsed = np.zeros(n, dtype=np.int64)  # decisions since the copy's reset
        self._autoreset = np.zeros(n, dtype=bool)
        self._kernel = compiled_kernel(
            "gym4real.microgrid.vector_kernel", "step_copies", compiled, "pip install gym4real-microgrid[fast]"
        )
        if self._kernel is not None:
            self._compiled_args = self._kernel_constants()

    @property
    def exact_copies(self) -> bool:
        """Whether every copy gives the single env's numbers bit for bit: with the compiled step (numba)."""
        return self._kernel is not None

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

    def _ambient(self, rows: Array) -> Array:
        """The ambient temperature of the data rows ``rows`` (as the single env's aligned step)."""
        s = self.single
        return self._temp_amb[(rows * s._step_s // s.world.temp_step).astype(np.int64) % len(self._temp_amb)]

    def _kernel_constants(self) -> tuple[Any, ...]:
        """The compiled step's tables and constants (:func:`~gym4real.microgrid.vector_kernel.step_copies`)."""
        s, p, t = self.single, self.single.battery_params, self.twin
        a, cal, soh = p.aging, p.aging.calendar, self._soh_obs is not None
        hourly = np.column_stack([self._pv, self._ask, self._bid, self._ambient(np.arange(s._n_rows))])
        constants = (
            *(s._step_s, p.soc_min, p.soc_max, p.current_min, p.current_max, p.power_min, p.power_max),
            *(p.c_thermal, t._r_tot, p.nominal_capacity, t.eol_soh, s._hours_per_step, s._deg_per_soh, KELVIN),
        )
        aging = (
            *(a.alpha_sei, a.beta_sei, a.k_t, a.k_soc, a.soc_ref, a.k_temp, a.temp_ref),
            *(a.k_delta1, a.k_delta2, a.k_delta3),
        )
        return (
            (self._demand, hourly, self._exogenous),
            (t._temps, t._socs, t._values, t._dvdt_x, t._dvdt_y),
            tuple(float(v) for v in constants),
            tuple(float(v) for v in aging),
            np.array([CYCLIC_FACTORS.index(f) for f in a.cyclic], dtype=np.int64),
            (self.config.decision_interval, int(t._timed), int("soc" in cal), int("temperature" in cal), int(soh)),
        )

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
        demand = self._demand[self._col, (row - 1) % self._demand.shape[1]]
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

    def _hours_numpy(self, a: Array) -> tuple[Array, Array, Array, Array, Array]:
        """The decision's hours of every copy in numpy (the copies that ended go on, their values frozen).

        Returns:
            The sums (rows :data:`SUMS`), terminated, truncated, the observation (:meth:`_obs`) and the
            SoC, SoH and temperature (rows) of every copy where its decision ended.
        """
        n, s, t = self.num_envs, self.single, self.twin
        interval, dt, hours = self.config.decision_interval, s._step_s, s._hours_per_step
        sums = np.zeros((len(SUMS), n))
        active = np.ones(n, dtype=bool)
        terminated, truncated = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
        frozen: Array | None = None  # observation and state of the copies that ended inside the interval
        for _ in range(interval):
            r = self._row
            demand = self._demand[self._col, r % self._demand.shape[1]]
            t_amb = self._ambient(r)
            gen = self._pv[r % s._hour_mod]
            margin = gen - demand
            request = margin * a
            soh0 = t.soh.copy()
            applied = t.step(request, dt, t_amb)
            traded = margin - applied
            now = r % s._hour_mod
            bought = traded < 0.0
            terms = np.stack(
                [
                    traded * np.where(bought, self._ask[now], self._bid[now]) * hours,
                    -((soh0 - t.soh) * s._deg_per_soh),
                    -(np.abs(request - applied) * hours),
                    t.violation,
                    demand * hours,
                    gen * hours,
                    np.where(applied > 0.0, applied * hours, 0.0),
                    -np.where(applied > 0.0, 0.0, applied * hours),
                    np.where(bought, 0.0, traded * hours),
                    -np.where(bought, traded * hours, 0.0),
                ]
            )  # the single env adds or subtracts each: x - y is x + (-y) exactly
            sums += terms if interval == 1 else np.where(active, terms, 0.0)
            self._row += 1
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
        obs, state = self._obs(), t.state[OBSERVED_STATE]
        if frozen is not None:
            done = terminated | truncated
            obs[done] = frozen[done, :-3]
            state[:, done] = frozen[done, -3:].T
        return sums, terminated, truncated, obs, state

    def _hours_compiled(self, a: Array) -> tuple[Array, Array, Array, Array, Array]:
        """:meth:`_hours_numpy` as one compiled loop over the copies; a copy stops where it ends.

        The copies that ended at the previous step are skipped (they restart now, their action unused).

        Returns:
            As :meth:`_hours_numpy` (the observation of the skipped copies is left at 0).
        """
        n, t, rf = self.num_envs, self.twin, self.twin.rainflow
        rf.reserve(self.config.decision_interval)  # at most one reversal an hour
        sums, ended = np.zeros((len(SUMS), n)), np.zeros((2, n), dtype=bool)
        obs = np.zeros(self._obs_shape, dtype=np.float32)
        exogenous, grid, constants, aging, cyclic, flags = self._compiled_args
        self._kernel(
            *(a, self._autoreset, t.state, rf.stack, rf.size, rf.walk, rf.last, rf.damage, self._clock),
            *(exogenous, grid, constants, aging, cyclic, flags, sums, ended, obs),
        )
        return sums, ended[0], ended[1], obs, t.state[OBSERVED_STATE]

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Route each copy's fraction of its net power to its battery for ``decision_interval`` hours.

        Args:
            actions: One fraction in ``[0, 1]`` per copy.

        Returns:
            Batched observation, reward, terminated, truncated and ``info`` (arrays, one value per copy).
        """
        obs, reward, terminated, truncated, reported = self._step(actions)
        reset, comps, pure, energy, cost, soc, soh, temperature = reported
        n = self.num_envs
        # the copies restarted now report these from their reset, as the single env's reset info has them
        info = with_masks(
            {"reward_components": comps, "pure_components": pure, "cost": cost, "soc": soc, "soh": soh}, n
        )
        info.update(with_masks({"temperature": temperature, "energy": energy}, n, present=~reset))  # only a step's
        return obs, reward, terminated, truncated, info

    def step_arrays(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`step` without building its ``info`` (about a quarter of the step's time), for a trainer's rollout.

        Read through :func:`gym4real.core.vector.step_arrays`.
        """
        obs, reward, terminated, truncated, _ = self._step(actions)
        return obs, reward, terminated, truncated

    def _step(self, actions: np.ndarray) -> tuple[Array, Array, Array, Array, tuple[Any, ...]]:
        """:meth:`step`'s arrays, and what its ``info`` reports: the copies reset now, components, energy, state."""
        a = self._actions(actions)
        s, t = self.single, self.twin
        hours = self._hours_numpy if self._kernel is None else self._hours_compiled
        sums, terminated, truncated, obs, (soc, soh, temperature) = hours(a)
        trading, degradation, clipping, cost = sums[:4]
        energy = dict(zip(SUMS[4:], sums[4:], strict=True))

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
        return obs, reward, terminated, truncated, (reset, comps, pure, energy, cost, soc, soh, temperature)
