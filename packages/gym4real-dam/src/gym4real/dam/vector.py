"""A native batched DamEnv: N copies of the lake integrated together with numpy (corrected mode only)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from gym4real.core.actions import box_actions
from gym4real.core.errors import ConfigError
from gym4real.core.vector import (
    check_max_episode_steps,
    compiled_kernel,
    copy_generators,
    per_copy,
    scalar_power,
    with_masks,
)
from gym4real.dam.config import DamConfig
from gym4real.dam.env import _RESET_OPTIONS, COMPONENTS, RELEASE, DamEnv

_NEEDED_FIXES = ("current_level_observation", "np_random_years")


class DamVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """``num_envs`` copies of :class:`~gym4real.dam.env.DamEnv` in arrays, with the same dynamics.

    ## Description
    Every copy is a Lake Como of the single env: each step integrates all copies' days together, sub-step
    by sub-step (``integration`` hourly sub-steps), with the release clipped into ``[q_min, q_max]`` and
    the five reward terms computed on arrays. The numbers are the single env's, bit for bit: with numba
    (the extra ``fast``) the sub-steps run compiled; without it in numpy, with the C library's ``pow`` value by
    value on the rating curve (numpy's vectorised power differs in the last bit for about 5 % of arguments).
    The copies run the nominal model: the single env's
    :meth:`~gym4real.dam.env.DamEnv.perturb` hook is not batched.

    ## Action Space
    ``Box(0.0, 491.61, (num_envs, 1), float32)``, the single env's box per copy (an array of shape
    ``(num_envs,)`` is accepted too). Out of the box: clipped or ValueError, as ``invalid_action`` says;
    a NaN or another shape always raises ValueError.

    ## Observation Space
    The single env's observation per copy, ``(num_envs, D)`` float32.

    ## Rewards
    The single env's reward per copy; ``info["reward_components"]`` maps each of the five terms to an
    array of ``num_envs`` weighted values; ``info["cost"]`` is 1.0 for copies ending the day in overflow
    or starvation.

    ## Starting State
    Copy ``i`` of ``reset(seed=s)`` is the single env's ``reset(seed=s + i)``: the same year, from its own
    generator (random years) or year number ``(s + i) % n_years`` (cycle). Later resets continue each
    copy as the single env continues without a seed. Without any seed, copy ``i`` of a cycle starts at
    year number ``i`` (so 13 copies of the ``test`` preset cover the 13 test years). ``options`` as in the
    single env: ``year`` (one year, or one per copy), ``init_level`` (one level, or one per copy, m),
    ``rewind_profiles``.

    ## Episode End
    All copies truncate together after ``sim_horizon`` days; the step after that resets every copy
    (Gymnasium's next-step autoreset, zero reward). The step at the horizon's ``info`` holds
    ``recorded_level_rmse`` per copy (NaN for a year without recorded levels).

    ## Arguments
    ``gymnasium.make_vec("gym4real/dam-v0", num_envs=N, vectorization_mode="vector_entry_point", **kwargs)``
    or ``DamVectorEnv(num_envs, config=None, preset=None, max_episode_steps=None, **overrides)``, with the
    single env's config, presets and overrides; ``max_episode_steps`` truncates every copy after that many
    steps, as Gymnasium's ``TimeLimit`` does to the single env. With numba installed (the extra ``fast``)
    each day is integrated in one compiled loop; ``compiled=False`` uses numpy (the same numbers),
    ``compiled=True`` requires numba. Only ``fidelity="corrected"`` with the
    ``current_level_observation`` and ``np_random_years`` fixes is batched (ValueError otherwise; use
    ``SyncVectorEnv`` for the reference).
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        config: DamConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        max_episode_steps: int | None = None,
        compiled: bool | None = None,
        **overrides: Any,
    ) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be a positive count of copies, not {num_envs}")
        self.single = s = DamEnv(config, preset=preset, **overrides)
        self.max_episode_steps = check_max_episode_steps(max_episode_steps)
        self.config = cfg = s.config
        missing = [f for f in _NEEDED_FIXES if not s._fixes[f]]
        if cfg.fidelity != "corrected" or missing:
            msg = (
                f'the batched dam supports fidelity="corrected" with the fixes {list(_NEEDED_FIXES)} only '
                f"(got fidelity={cfg.fidelity!r}, fixes off: {missing}); "
                "use gymnasium.make_vec(..., vectorization_mode='sync')"
            )
            raise ValueError(msg)
        self.num_envs = num_envs
        self.single_observation_space = s.observation_space
        self.single_action_space = s.action_space
        self.observation_space = batch_space(s.observation_space, num_envs)
        self.action_space = batch_space(s.action_space, num_envs)
        self._load_tables()
        self._kernel = compiled_kernel(
            "gym4real.dam.vector_kernel", "integrate_copies", compiled, "pip install gym4real-dam[fast]"
        )
        self._rngs: list[np.random.Generator] | None = None
        self._cycle: np.ndarray | None = None
        self._needs_reset = False
        self._start(np.zeros(num_envs, dtype=np.int64), np.full(num_envs, cfg.lake.init_level))

    def _load_tables(self) -> None:
        """Per year and step: demand, inflow, minimum flow, evaporation, deficit weight; recorded levels."""
        s, H = self.single, self.config.sim_horizon
        episodes = [s._episode(year) for year in s.years]
        self._exo = np.array(
            [list(zip(e.demand, e.inflow, e.min_flow, e.evaporation, e.deficit_weight, strict=True)) for e in episodes]
        )
        self._recorded = np.array([e.recorded_level or [np.nan] * H for e in episodes])
        self._evaporation = any(e.evaporation != (0.0,) * H for e in episodes)
        self._years = np.array(s.years)
        lake = s.lake
        self._area, self._lmin, self._lmax, self._llim = lake.surface, lake.min_level, lake.max_level, lake.linear_limit
        self._k, self._c, self._alpha, self._beta, self._cr = (
            lake.linear_slope,
            lake.linear_intercept,
            lake.alpha,
            lake.beta,
            lake.C_r,
        )
        self._dt, self._substeps = lake.dt, lake.substeps
        self._lake = (  # the compiled day's constants, in its order
            float(self._area),
            float(self._lmin),
            float(self._lmax),
            float(self._llim),
            float(self._k),
            float(self._c),
            float(self._alpha),
            float(self._beta),
            float(self._cr),
            float(self._dt),
        )
        self._sin, self._cos = np.array(s._sin), np.array(s._cos)

    def _start(self, year_index: np.ndarray, level: np.ndarray) -> None:
        n = self.num_envs
        self._yi = year_index
        self._t = 0
        self._level = level.astype(np.float64)
        self._storage = self._area * (self._level - self._lmin)  # Lake.level_to_storage
        self._ead = np.zeros(n)
        self._squared_gap = np.zeros(n)

    @property
    def years(self) -> np.ndarray:
        """The year of each copy's current episode."""
        return self._years[self._yi]

    @property
    def level(self) -> np.ndarray:
        """The current lake level of each copy (m)."""
        return self._level.copy()

    @property
    def storage(self) -> np.ndarray:
        """The current storage of each copy (m3)."""
        return self._storage.copy()

    def _observe(self) -> np.ndarray:
        s, t = self.single, self._t
        obs = np.empty((self.num_envs, s.observation_space.shape[0]), dtype=np.float32)
        if s._i_level is not None:
            obs[:, s._i_level] = self._level
        if s._i_day is not None:
            obs[:, s._i_day] = self._sin[t]
            obs[:, s._i_day + 1] = self._cos[t]
        if s._i_ead is not None:
            obs[:, s._i_ead] = self._ead
        return obs

    # -- reset -------------------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode in every copy (see Starting State).

        Args:
            seed: Copy ``i`` starts as the single env reset with ``seed + i``; None continues each copy.
            options: ``year`` (a year of the split, or one per copy), ``init_level`` (m, one or one per
                copy), ``rewind_profiles`` (restart the cycle of years).

        Returns:
            The observations and an info dict of arrays: ``year``, ``level``, ``storage``.
        """
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = sorted(set(options) - set(_RESET_OPTIONS))
        if unknown:
            raise ValueError(f"unknown reset options {unknown}; expected some of {list(_RESET_OPTIONS)}")
        level = self._init_levels(options.get("init_level"))
        year_index = self._select_years(seed, options)
        self._start(year_index, level)
        self._needs_reset = False
        n = self.num_envs
        info = {
            "year": self.years,
            "level": self.level,
            "storage": self.storage,
            "reward_components": {k: np.zeros(n) for k in COMPONENTS},
            "cost": np.zeros(n),
        }
        return self._observe(), with_masks(info, n)

    def _select_years(self, seed: int | None, options: dict[str, Any]) -> np.ndarray:
        years, copies = self.single.years, np.arange(self.num_envs)
        if options.get("year") is not None:
            wanted = per_copy(options["year"], self.num_envs, "year").tolist()
            bad = [y for y in dict.fromkeys(wanted) if y not in years]
            if bad:
                raise ValueError(f"reset option `year`: {bad} are not years of this env {list(years)}")
        if self.config.year_selection == "random":
            self._rngs = copy_generators(self, self._rngs, seed)
        if options.get("year") is not None:
            self._cycle = np.array([years.index(y) for y in wanted])
            return self._cycle
        if self._rngs is not None:
            return np.array([int(rng.integers(len(years))) for rng in self._rngs])
        if options.get("rewind_profiles"):
            self._cycle = None
        if seed is not None:
            self._cycle = (seed + copies) % len(years)
        elif self._cycle is None:
            self._cycle = copies % len(years)
        else:
            self._cycle = (self._cycle + 1) % len(years)
        return self._cycle

    def _init_levels(self, value: Any) -> np.ndarray:
        if value is None:
            return np.full(self.num_envs, self.config.lake.init_level)
        levels = per_copy(value, self.num_envs, "init_level").astype(np.float64)
        for level in np.unique(levels):
            if not np.isfinite(level):
                raise ValueError(f"reset option `init_level` must hold finite levels in m, not {level}")
            try:
                self.single._check_level_bounds(float(level))
            except ConfigError as exc:
                raise ValueError(f"reset option `init_level`: {exc}") from None
        return levels

    # -- step --------------------------------------------------------------------------------------

    def _decisions(self, actions: Any) -> np.ndarray:
        """The actions as float64 releases inside the box (clipped, or ValueError, as configured)."""
        clip = self.config.invalid_action == "clip"
        fix = 'clip them, or set `invalid_action="clip"`'
        space, n = self.single_action_space, self.num_envs
        a = box_actions(actions, space, n, RELEASE, outside="clip" if clip else "raise", fix=fix)
        return a.reshape(self.num_envs)

    def _integrate(
        self, decision: np.ndarray, inflow: np.ndarray, min_flow: np.ndarray, evaporation: np.ndarray
    ) -> np.ndarray:
        """Integrate every copy's day in place (``_storage``); return the mean releases.

        Per sub-step, as :meth:`Lake.trace`: ``h = s / A + l_min``, the release ``min(q_max(h),
        max(q_min(h), decision))`` (0 up to l_min; the rating curve above l_max) and
        ``s += dt ((inflow - release) - evaporation)``; the mean sums in ``numpy.mean``'s order.
        """
        n, dt = self.num_envs, self._dt
        wanted = np.maximum(decision, min_flow)  # max(q_min, decision) between l_min and l_max
        releases = np.empty((self._substeps, n))
        if self._kernel is not None:  # the same expressions, compiled
            self._kernel(self._storage, wanted, inflow, evaporation, self._lake, self._evaporation, releases)
            return pairwise_column_sums(releases) / self._substeps
        s = self._storage
        h, q_max, net, mask = np.empty(n), np.empty(n), np.empty(n), np.empty(n, bool)
        for r in releases:
            np.divide(s, self._area, out=h)
            h += self._lmin
            np.multiply(h, self._k, out=q_max)
            q_max += self._c  # the linear part: q_max up to l_lim
            np.greater(h, self._llim, out=mask)
            if mask.any():  # the rating curve above l_lim, with libm's pow as the single env
                q_max[mask] = scalar_power(h[mask] - self._alpha, self._beta) * self._cr
            np.minimum(q_max, wanted, out=r)
            np.greater(h, self._lmax, out=mask)
            np.copyto(r, q_max, where=mask)  # above l_max, q_min = q_max: the rating curve
            np.less_equal(h, self._lmin, out=mask)
            np.copyto(r, 0.0, where=mask)
            np.subtract(inflow, r, out=net)
            if self._evaporation:
                net -= evaporation
            net *= dt
            s += net
        return pairwise_column_sums(releases) / self._substeps

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Release water for one day in every copy.

        Args:
            actions: The target releases (m3/s), shape ``(num_envs, 1)`` or ``(num_envs,)``.

        Returns:
            Observations, rewards, terminated (never), truncated (all copies at the horizon), and an info
            dict of arrays: ``reward_components``, ``cost``, ``level``, ``storage``, ``release``, ``year``
            (and ``recorded_level_rmse`` when truncating).
        """
        n = self.num_envs
        if self._needs_reset:
            obs, start = self.reset()
            return obs, np.zeros(n), np.zeros(n, dtype=bool), np.zeros(n, dtype=bool), start
        a = self._decisions(actions)
        t, s = self._t, self.single
        demand, inflow, min_flow, evaporation, weight = self._exo[self._yi, t].T
        self._squared_gap += (self._level - self._recorded[self._yi, t]) ** 2
        self._ead = s._ead_c * self._ead + s._ead_1c * demand
        release = self._integrate(a, inflow, min_flow, evaporation)
        level = self._level = self._storage / self._area + self._lmin

        # reward: the single env's expressions, in its order of operations
        overflow = np.where(level > s._flood, -1.0, 0.0)
        starving = np.where(level < s._starving, -1.0, 0.0)
        deficit = np.maximum(demand - np.maximum(release - min_flow, 0.0), 0.0) * weight
        wasted = -np.maximum(release - demand, 0.0)
        clipping = -((a - release) ** 2)
        components = {
            "deficit": -deficit * s._w_deficit,
            "overflow": overflow * s._w_overflow,
            "starving": starving * s._w_starving,
            "wasted_water": wasted * s._w_wasted,
            "clipping": clipping * s._w_clip,
        }
        reward = (
            components["overflow"]
            + components["starving"]
            + components["deficit"]
            + components["wasted_water"]
            + components["clipping"]
        )
        self._t = t = t + 1
        truncated = t >= s._H or t == self.max_episode_steps
        self._needs_reset = truncated
        info: dict[str, Any] = {
            "reward_components": components,
            "cost": np.where((overflow != 0) | (starving != 0), 1.0, 0.0),
            "level": level.copy(),
            "storage": self._storage.copy(),
            "release": release,
            "year": self.years,
        }
        if t >= s._H:
            info["recorded_level_rmse"] = np.sqrt(self._squared_gap / t)
        return self._observe(), reward, np.zeros(n, dtype=bool), np.full(n, truncated), with_masks(info, n)


def pairwise_column_sums(values: np.ndarray) -> np.ndarray:
    """Sum the columns of an ``(n, N)`` array in the order of :func:`gym4real.dam.lake.np_sum`.

    That is numpy's pairwise summation of each column, done on whole rows (bit-identical to
    ``numpy.sum`` of each column as a contiguous array).
    """
    n = values.shape[0]
    if n < 8:
        res = np.full(values.shape[1], -0.0)
        for row in values:
            res += row
        return res
    if n <= 128:
        top = n - n % 8
        acc = values[:8].copy()
        for i in range(8, top, 8):
            acc += values[i : i + 8]
        res = ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
        for row in values[top:]:
            res += row
        return res
    half = n // 2
    half -= half % 8
    return pairwise_column_sums(values[:half]) + pairwise_column_sums(values[half:])
