"""Configuration of WDSEnv (reference values: ../shared/data/reference-configs/wds/world_anytown.yaml)."""

from __future__ import annotations

from typing import Literal, Self

from pydantic import Field, model_validator

from gym4real.core.config import ConfigSection, EnvConfig


class EventProbs(ConfigSection):
    """Probabilities of the demand buckets for training draws (they must sum to 1)."""

    normal: float = Field(0.6, ge=0, le=1, description="Probability of a `normal` profile file.")
    stressful: float = Field(0.35, ge=0, le=1, description="Probability of a `stressful` profile file.")
    extreme: float = Field(0.05, ge=0, le=1, description="Probability of an `extreme` profile file.")

    @model_validator(mode="after")
    def _sum_to_one(self) -> Self:
        total = self.normal + self.stressful + self.extreme
        if abs(total - 1.0) > 1e-9:
            raise ValueError(f"demand.event_probs must sum to 1 (got {total:g})")
        return self


class DemandSection(ConfigSection):
    """Demand profiles and the demand estimate of the observation."""

    event_probs: EventProbs = EventProbs()
    split: Literal["train", "test"] = Field(
        "train",
        description="Profiles drawn at reset: `train` (bucket, file, week) or `test` (a column of test1000.csv).",
    )
    test_indices: tuple[int, int] = Field(
        (0, 1000), description="[start, stop) of the test profiles drawn when `split` is `test` and no index is given."
    )
    estimate: Literal["sma", "ewma"] = Field(
        "sma", description="Demand estimate in the observation: simple or exponentially weighted moving average."
    )
    window: int = Field(6, ge=1, description="Window (SMA) or span (EWMA) of the estimate, in pattern steps (hours).")

    @model_validator(mode="after")
    def _indices(self) -> Self:
        lo, hi = self.test_indices
        if not 0 <= lo < hi <= 1000:
            raise ValueError(f"demand.test_indices must satisfy 0 <= start < stop <= 1000 (got {self.test_indices})")
        return self


class RewardSection(ConfigSection):
    """Reward weights and the overflow threshold."""

    dsr_coeff: float = Field(1.0, ge=0, description="Weight of the demand satisfaction ratio.")
    overflow_coeff: float = Field(0.25, ge=0, description="Weight of the overflow-risk penalty.")
    lambda_of: float = Field(
        0.95,
        gt=0,
        lt=1,
        description="Overflow threshold as a fraction of the tank's maximum level: 0.95 in the reference code, "
        "0.9 in the paper's Table 9.",
    )


class PdaSection(ConfigSection):
    """Pressure-driven demand parameters (network pressure units); null keeps the network file's value."""

    minimum_pressure: float | None = Field(None, description="Pressure below which no demand is delivered.")
    required_pressure: float | None = Field(None, description="Pressure at which the full demand is delivered.")
    exponent: float | None = Field(None, gt=0, description="Exponent of the pressure-demand relation.")


class PumpRuleConfig(ConfigSection):
    """One pump's tank-level rule, used by the `default` baseline when the network file has none."""

    pump: str = Field(description="Pump id.")
    tank: str = Field(description="Tank id whose level drives the pump.")
    low: float = Field(description="Open the pump when the level is below this (network length units).")
    high: float = Field(description="Close the pump when the level is above this.")

    @model_validator(mode="after")
    def _order(self) -> Self:
        if self.low >= self.high:
            raise ValueError(f"rule for `{self.pump}`: low ({self.low}) must be below high ({self.high})")
        return self


class ObservationSection(ConfigSection):
    """Which junction pressures the observation holds."""

    junctions: list[str] | None = Field(
        None, description="Junction ids whose pressure is observed, in this order; null for all junctions."
    )


class FixesSection(ConfigSection):
    """Individual switches of the reference defects; null follows `fidelity`."""

    fixed_interval: bool | None = Field(
        None,
        description="True: one step per `decision_interval`, EPANET events handled inside, observation at the end "
        "of the interval. False (upstream): one step per EPANET event, the hydraulic step clamped by the file's "
        "report step, tank levels at t + dt beside pressures at t.",
    )
    dsr_reference: Literal["current", "first_hour"] | None = Field(
        None,
        description="`current`: delivered over full demand at the current multiplier. `first_hour` (upstream): "
        "over the hour-0 demand, 0 when that is not positive.",
    )
    per_episode_estimate: bool | None = Field(
        None, description="Recompute the demand estimate every episode (upstream: once per env lifetime)."
    )
    exact_tank_events: bool | None = Field(
        None,
        description="Snap a tank that EPANET would empty or fill in under half a second to its limit before "
        "solving (EPANET rounds event times to whole seconds and otherwise lets an all-but-empty tank supply "
        "a whole hydraulic step, breaking the water balance). Upstream: off.",
    )
    initial_observation: Literal["solved", "zeros"] | None = Field(
        None, description="`solved`: the network solved at t = 0; `zeros` (upstream): tanks and pressures at 0."
    )


class WDSConfig(EnvConfig):
    """Validated parameters of :class:`~gym4real.wds.env.WDSEnv`."""

    presets_package = "gym4real.wds"

    network: str | None = Field(
        None, description="Path of an EPANET `.inp` network; null for the registered Anytown network."
    )
    engine: Literal["auto", "owa-epanet", "epyt"] = Field(
        "auto", description="EPANET binding: `auto` prefers owa-epanet and falls back to epyt's library."
    )
    duration: int = Field(604_800, ge=1, description="Simulated seconds per episode (one week).")
    decision_interval: int = Field(3600, ge=1, description="Seconds between decisions (corrected stepping).")
    hydraulic_step: int = Field(
        600,
        ge=1,
        description="Requested EPANET hydraulic step (s), the step of EPANET's explicit integration of tank "
        "levels. Corrected: clamped to the decision interval and the pattern step; 600 s keeps tank levels within "
        "0.2 m of a converged (60 s) run, 3600 s (preset `hourly_hydraulics`) drifts by 1-1.6 m in a week. "
        "Upstream: clamped by the file's report step (600 s for Anytown), as in the reference.",
    )
    pattern_step: int = Field(3600, ge=1, description="Seconds per demand multiplier (the profiles are hourly).")
    demand: DemandSection = DemandSection()
    reward: RewardSection = RewardSection()
    observation: ObservationSection = ObservationSection()
    pda: PdaSection = PdaSection()
    default_rule: list[PumpRuleConfig] = Field(
        default_factory=lambda: [
            PumpRuleConfig(pump="P78", tank="T41", low=5.0, high=8.0),
            PumpRuleConfig(pump="P79", tank="T42", low=5.0, high=8.0),
        ],
        description="Tank-level rules of the `default` baseline when the network's [CONTROLS] holds none.",
    )
    pump_control: Literal["agent", "controls"] = Field(
        "agent",
        description="`agent`: the action switches the pumps; the network's pump controls and rules are disabled. "
        "`controls`: EPANET executes the network's pump controls itself all episode (active ones as they are; "
        "else the tank-level rule of `[CONTROLS]`, commented out or not, or `default_rule`), switching a pump "
        "the moment its tank crosses a level; the action is checked but not applied. The paper's Default expert, "
        "which the `default` baseline approximates with hourly decisions.",
    )
    seed: int = Field(42, description="Seed of the upstream mode's draws until `reset(seed=...)` re-seeds them.")
    fixes: FixesSection = FixesSection()

    @model_validator(mode="after")
    def _times(self) -> Self:
        if self.duration % self.decision_interval:
            msg = f"duration ({self.duration}) must be a multiple of decision_interval ({self.decision_interval})"
            raise ValueError(msg)
        return self
