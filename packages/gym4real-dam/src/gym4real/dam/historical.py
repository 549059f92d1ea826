"""The historical operators of Lake Como: releases reconstructed from the recorded levels and inflows.

Inverting the mass balance of a day, ``A (l_{d+1} - l_d) = 86400 (inflow_d - release_d - evaporation_d)``,
gives the release the operators made on day ``d``. Replayed in the lake model from the recorded start
level, these releases reproduce the recorded levels exactly except on days where the model's release
bounds ``[q_min, q_max]`` (or the action box) clip them; :func:`reconstruction_report` measures that
reconstruction error per year. ``python -m gym4real.dam.historical [train|test]`` prints it.

The policy :class:`Historical` plays the operators in the environment (expert data for imitation
learning): ``mode="replay"`` releases the reconstructed release of the day; ``mode="track"`` (the
``historical`` baseline) releases what brings the lake from its *current* level to the next day's recorded
level. On the recorded trajectory both are the same release; ``track`` also follows the record when the
episode starts elsewhere (the benchmark starts every year at 0.35 m) or after a clipped day.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from gym4real.core.datasets import resolve
from gym4real.dam.data import DAYS, YearlyTable, calendar_days, read_yearly
from gym4real.dam.lake import SECONDS_PER_DAY

if TYPE_CHECKING:
    from gym4real.dam.env import DamEnv


def reconstruct_releases(
    levels: Sequence[float], inflows: Sequence[float], surface: float, evaporation: Sequence[float] | None = None
) -> list[float]:
    """Daily releases (m3/s) from start-of-day levels (m) and daily inflows (m3/s) by mass balance.

    Args:
        levels: Levels at the start of each day and of the day after the last (one more than ``inflows``).
        inflows: Mean inflow of each day.
        surface: Lake surface (m2).
        evaporation: Mean evaporation flow of each day (m3/s); none by default.
    """
    if len(levels) < len(inflows) + 1:
        raise ValueError(f"need {len(inflows) + 1} levels for {len(inflows)} days, got {len(levels)}")
    evap = evaporation if evaporation is not None else [0.0] * len(inflows)
    return [inflows[d] - evap[d] - surface * (levels[d + 1] - levels[d]) / SECONDS_PER_DAY for d in range(len(inflows))]


class RecordedLevels:
    """The recorded start-of-day levels of each year, with the next year's first day appended.

    Args:
        data_dir: Data folder (as the env config's ``data_dir``).
        drop_feb29: Leap-year handling, as the environment's ``fixes.drop_feb29``.
    """

    def __init__(self, data_dir: str | None, drop_feb29: bool) -> None:
        self.tables: list[YearlyTable] = [
            read_yearly(resolve(f"dam/level/{split}", data_dir), "level") for split in ("train", "test")
        ]
        self.drop_feb29 = drop_feb29
        self._cache: dict[int, list[float | None]] = {}

    def _row(self, year: int) -> YearlyTable | None:
        return next((t for t in self.tables if year in t.values), None)

    def __call__(self, year: int) -> list[float | None]:
        """Levels of days 0..364 of ``year`` and, at index 365, of the following day (None if unrecorded)."""
        if year in self._cache:
            return self._cache[year]
        table = self._row(year)
        if table is None:
            raise KeyError(f"no recorded levels for year {year}")
        levels: list[float | None] = list(calendar_days(table, year, self.drop_feb29))
        series = table.values[year]
        if len(series) > DAYS and not self.drop_feb29:
            levels.append(series[DAYS])  # the reference's leap years end on 30 December: 31 December follows
        else:
            nxt = self._row(year + 1)
            levels.append(nxt.values[year + 1][0] if nxt is not None else None)
        self._cache[year] = levels
        return levels


class Historical:
    """The historical operators' release (see the module docstring).

    Args:
        env: A DamEnv (or a wrapper of one); the policy reads its current year, day and level.
        mode: ``"track"`` (follow the recorded level from the current one) or ``"replay"``.
    """

    def __init__(self, env: gym.Env[Any, Any], mode: str = "track") -> None:
        if mode not in ("track", "replay"):
            raise ValueError(f'`mode` must be "track" or "replay", not {mode!r}')
        self.env: DamEnv = env.unwrapped  # type: ignore[assignment]
        self.mode = mode
        cfg = self.env.config
        self.levels = RecordedLevels(cfg.data_dir, self.env._fixes["drop_feb29"])
        self.low = float(self.env.action_space.low[0])
        self.high = float(self.env.action_space.high[0])

    def release(self) -> float:
        """The unclipped historical release of the env's current day (m3/s)."""
        base = self.env
        ep, t = base.episode, base.current_step
        recorded = self.levels(ep.year)
        day = ep.day[t]
        start = recorded[day] if self.mode == "replay" else base.level
        target = recorded[day + 1]
        if start is None:
            start = base.level
        if target is None:  # the day after the record ends: hold the level
            target = start
        return ep.inflow[t] - ep.evaporation[t] - base.lake.surface * (target - start) / SECONDS_PER_DAY

    def __call__(self, obs: Any) -> np.ndarray:
        """Return the historical release, clipped into the action box.

        In float64, wider than the box's float32: the reconstruction reproduces the recorded levels to
        rounding error only at full precision (float32 rounding moves releases that sit on a bound).
        """
        return np.array([min(max(self.release(), self.low), self.high)])


def reconstruction_report(
    split: str = "test", data_dir: str | None = None, **env_kwargs: Any
) -> list[dict[str, float | int]]:
    """Replay the reconstructed releases of every year of a split from its recorded start level.

    Returns one row per year: ``negative_days`` (days whose reconstructed release is negative),
    ``clipped_days`` (days whose realised mean release differs from the reconstructed one by more than
    1e-6 m3/s: the lake's bounds or the action box clipped it), ``level_rmse`` and ``level_max_error``
    (m, simulated vs recorded start-of-day levels over the episode's days) and ``objective`` (the paper's
    deficit + overflow + starving).
    """
    from gym4real.dam.env import DamEnv

    env = DamEnv(split=split, year_selection="cycle", data_dir=data_dir, **env_kwargs)
    policy = Historical(env, mode="replay")
    rows = []
    for year in env.years:
        recorded = policy.levels(year)
        env.reset(options={"year": year, "init_level": recorded[env.episode.day[0]]})
        negative = clipped = 0
        objective = 0.0
        simulated = [env.level]
        done = False
        while not done:
            wanted = policy.release()
            negative += wanted < 0
            _, _, _, done, info = env.step(policy(None))
            clipped += abs(info["release"] - wanted) > 1e-6
            simulated.append(env.level)
            comps = info["reward_components"]
            objective += comps["deficit"] + comps["overflow"] + comps["starving"]
        errors = [
            s - r for s, r in zip(simulated, (recorded[d] for d in env.episode.day), strict=False) if r is not None
        ]
        rows.append(
            {
                "year": year,
                "negative_days": negative,
                "clipped_days": clipped,
                "level_rmse": math.sqrt(sum(e * e for e in errors) / len(errors)),
                "level_max_error": max(abs(e) for e in errors),
                "objective": objective,
            }
        )
    return rows


def main(argv: Sequence[str] | None = None) -> None:
    """Print the reconstruction report of a split (``train`` or ``test``, default ``test``)."""
    args = list(sys.argv[1:] if argv is None else argv)
    split = args[0] if args else "test"
    rows = reconstruction_report(split)
    print(f"{'year':>6} {'negative':>8} {'clipped':>8} {'rmse (m)':>9} {'max (m)':>8} {'objective':>11}")
    for r in rows:
        print(
            f"{r['year']:>6} {r['negative_days']:>8} {r['clipped_days']:>8} {r['level_rmse']:>9.4f} "
            f"{r['level_max_error']:>8.4f} {r['objective']:>11.1f}"
        )
    rmse = [float(r["level_rmse"]) for r in rows]
    print(f"mean level RMSE {np.mean(rmse):.4f} m over {len(rows)} years")


if __name__ == "__main__":
    main()
