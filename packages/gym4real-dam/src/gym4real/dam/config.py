"""Configuration of DamEnv (reference values: ../shared/data/reference-configs/dam/*.yaml).

Field names follow the reference's ``lake.yaml`` and ``world_*.yaml`` so that a reference settings file
maps onto this model key by key (``random_init`` became ``year_selection``; data files are named by
split and resolved through the dataset registry).
"""

from __future__ import annotations

from typing import Literal, Self

from pydantic import Field, model_validator

from gym4real.core.config import ConfigSection, EnvConfig

Observation = Literal["day_of_year", "level", "exponential_average_demand"]


class LakeSection(ConfigSection):
    """The lake model (paper appendix, Table "DamEnv's simulator parameters")."""

    surface: float = Field(
        145_900_000.0, gt=0, description="Lake surface A (m2); constant, so storage is linear in level."
    )
    evaporation: bool = Field(False, description="Subtract the daily evaporation of `evaporation_rates`.")
    evaporation_rates: str | None = Field(
        None,
        description="CSV of 365 daily evaporation rates (mm/day, one numeric column with a header); "
        "required when `evaporation` is true.",
    )
    init_level: float = Field(0.35, description="Level at the start of every episode (m).")
    alpha: float = Field(-2.5, description="Zero-flow level of the rating curve (m).")
    beta: float = Field(2.015, gt=0, description="Rating-curve exponent.")
    C_r: float = Field(33.37, gt=0, description="Rating-curve (discharge) coefficient.")
    min_level: float = Field(-0.5, description="Level below which nothing is released (storage 0) (m).")
    max_level: float = Field(1.25, description="Level above which the release follows the rating curve (m).")
    linear_slope: float = Field(1488.1, ge=0, description="Slope k of the linear branch of q_max (m2/s).")
    linear_intercept: float = Field(744.05, description="Intercept c of the linear branch of q_max (m3/s).")
    linear_limit: float = Field(-0.4, description="Level up to which q_max is linear (m).")

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if not self.alpha < self.min_level < self.linear_limit < self.max_level:
            msg = "lake levels must satisfy `alpha` < `min_level` < `linear_limit` < `max_level`"
            raise ValueError(msg)
        if self.evaporation and not self.evaporation_rates:
            msg = (
                "`lake.evaporation` is true but `lake.evaporation_rates` is not set: name a CSV of 365 daily "
                "rates in mm/day (the reference crashes here)"
            )
            raise ValueError(msg)
        return self


class ActionSection(ConfigSection):
    """Bounds of the daily release decision (m3/s)."""

    low: float = Field(0.0, ge=0, description="Lowest release decision.")
    high: float = Field(491.61, gt=0, description="Highest release decision (rating curve at 1.30 m).")

    @model_validator(mode="after")
    def _ordered(self) -> Self:
        if self.high <= self.low:
            raise ValueError("`action.high` must be above `action.low`")
        return self


class RewardSection(ConfigSection):
    """Weights of the five reward terms."""

    daily_deficit_coeff: float = Field(1.0, ge=0, description="Weight of the seasonal supply deficit.")
    overflow_coeff: float = Field(1000.0, ge=0, description="Weight of a day ending above `flood_level`.")
    starving_coeff: float = Field(250.0, ge=0, description="Weight of a day ending below `starving_level`.")
    wasted_water_coeff: float = Field(0.2, ge=0, description="Weight of the release above demand.")
    clip_action_coeff: float = Field(0.0005, ge=0, description="Weight of (decision - realised release)^2.")


class FixesSection(ConfigSection):
    """Individual switches of the corrected behaviour; null follows `fidelity`."""

    current_level_observation: bool | None = Field(
        None,
        description="Observe the current level (the reference reads the level history at the day-of-year "
        "index: the final observation shows the initial level).",
    )
    inflow_by_day_of_year: bool | None = Field(
        None, description="Index the inflow by day of year like demand and MEF (the reference uses the step)."
    )
    np_random_years: bool | None = Field(
        None,
        description="Draw years from `np_random` seeded by `reset(seed=)` (the reference uses `random.Random`); "
        "in cycle mode a seeded reset picks year number `seed % n_years`.",
    )
    drop_feb29: bool | None = Field(
        None,
        description="Drop 29 February of leap years, keeping days aligned with the calendar (the reference "
        "keeps the first 365 values, i.e. drops 31 December).",
    )


class DamConfig(EnvConfig):
    """Validated parameters of :class:`~gym4real.dam.env.DamEnv`."""

    presets_package = "gym4real.dam"

    lake: LakeSection = LakeSection()
    period: int = Field(365, ge=1, le=365, description="Days per year in day-of-year arithmetic (T).")
    integration: int = Field(24, ge=1, le=86_400, description="Lake sub-steps per daily step (a count).")
    sim_horizon: int = Field(365, ge=1, le=36_500, description="Daily steps per episode (H), at most 100 years.")
    doy: int = Field(1, ge=1, le=365, description="Day of year (1-based) of the first step.")
    flood_level: float = Field(1.24, description="A day ending above this level counts as overflow (m).")
    starving_level: float = Field(-0.45, description="A day ending below this level counts as starving (m).")
    exponential_average_coeff: float = Field(0.8, ge=0, le=1, description="Smoothing of the average demand.")
    smooth_daily_deficit_coeff: bool = Field(
        True, description="Seasonal deficit weight 0.5 (3 - cos(2 pi d / 365)); false: 2 on days 121..243, else 1."
    )
    seed: int = Field(123, description="Seed of the year draws in upstream mode (`random.Random`).")
    split: Literal["train", "test"] = Field("train", description="Data files: 52 training or 13 test years.")
    years: list[int] | None = Field(None, description="Years of the split to use, in this order (null: all).")
    year_selection: Literal["random", "cycle"] = Field(
        "random", description="A random year at each reset, or the years in order (the reference `random_init`)."
    )
    observations: list[Observation] = Field(
        ["day_of_year", "level", "exponential_average_demand"],
        min_length=1,
        description="Features; always in the order level, sin/cos of day of year, average demand.",
    )
    action: ActionSection = ActionSection()
    reward: RewardSection = RewardSection()
    invalid_action: Literal["clip", "raise"] = Field(
        "clip",
        description='"clip": an action outside the box is clipped into it (the clipping term then charges '
        'the gap to the realised release); "raise": ValueError. A NaN always raises.',
    )
    max_inflow: float = Field(2000.0, gt=0, description="Largest inflow accepted in the data (m3/s).")
    max_demand: float = Field(1000.0, gt=0, description="Largest demand accepted in the data (m3/s).")
    level_bounds: tuple[float, float] = Field(
        (-1.0, 6.0), description="Declared level bounds (m); checked against every reachable level."
    )
    recorded_level: bool = Field(
        True, description="Load the recorded levels and report `recorded_level_rmse` at the end of an episode."
    )
    fixes: FixesSection = FixesSection()

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if len(set(self.observations)) != len(self.observations):
            raise ValueError("`observations` lists a feature twice")
        if self.doy > self.period:
            raise ValueError("`doy` must not exceed `period`")
        if self.starving_level >= self.flood_level:
            raise ValueError("`starving_level` must be below `flood_level`")
        low, high = self.level_bounds
        if low >= high:
            raise ValueError(f"`level_bounds` {self.level_bounds} must be (lowest, highest) level, lowest first")
        if not low <= self.lake.init_level <= high:
            msg = f"`lake.init_level` ({self.lake.init_level} m) must lie within `level_bounds` [{low}, {high}] m"
            raise ValueError(msg)
        if self.years is not None and len(set(self.years)) != len(self.years):
            raise ValueError("`years` lists a year twice")
        fixes = self.resolved_fixes()
        if not fixes["inflow_by_day_of_year"] and self.sim_horizon > 365:
            raise ValueError("`sim_horizon` above 365 needs `fixes.inflow_by_day_of_year` (the reference overruns)")
        if not fixes["current_level_observation"] and self.doy != 1:
            msg = (
                "`doy` other than 1 needs `fixes.current_level_observation`: the reference reads the level "
                "history at the day-of-year index and fails at the first reset"
            )
            raise ValueError(msg)
        return self

    def resolved_fixes(self) -> dict[str, bool]:
        """The fix switches with null replaced by the `fidelity` default (on when corrected)."""
        default = self.fidelity == "corrected"
        return {k: default if v is None else v for k, v in self.fixes.model_dump().items()}
