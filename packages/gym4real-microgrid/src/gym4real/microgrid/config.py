"""Configuration of MicrogridEnv (reference values: ../shared/data/reference-configs/microgrid/world_*.yaml)."""

from __future__ import annotations

from typing import Literal, Self

from pydantic import Field, model_validator

from gym4real.core.config import ConfigSection, EnvConfig


class DummySection(ConfigSection):
    """Constant series standing in for a missing generation, market or temperature file (reference values)."""

    generation: float = Field(10.0, ge=0, description="Constant PV generation (W).")
    ask: float = Field(0.00021, ge=0, description="Constant buy price (EUR/Wh).")
    bid: float = Field(0.00014, ge=0, description="Constant sell price (EUR/Wh).")
    temp_amb: float = Field(298.15, ge=150, description="Constant ambient temperature (K).")


class DataSection(ConfigSection):
    """The exogenous series: a registered dataset (``demand/test``), the path of a ``.csv`` file, or null."""

    demand: str = Field("demand/test", description="Demand profiles (W), one column per household.")
    generation: str | None = Field(
        "generation/test", description="PV generation of the 3 kW plant (W); null: `dummy.generation`."
    )
    market: str | None = Field(
        "market/test", description="GME prices: `ask` (buy) and `bid` (sell), EUR/Wh; null: `dummy.ask`/`bid`."
    )
    temp_amb: str | None = Field("temp_amb/test", description="Daily ambient temperature (K); null: `dummy.temp_amb`.")
    dummy: DummySection = DummySection()
    timestep: float = Field(
        3600.0, gt=0, le=86_400, description="Seconds per row of the demand, PV and market series (at most a day)."
    )
    temp_timestep: float = Field(
        86400.0, gt=0, le=86_400, description="Seconds per row of the ambient temperature series (at most a day)."
    )


class BatterySection(ConfigSection):
    """The battery: registered configuration files unless paths are given."""

    pack: str | None = Field(None, description="Pack YAML (`battery_pack.yaml`); null: the registered one.")
    electrical: str | None = Field(None, description="Electrical model YAML; null: the registered one.")
    thermal: str | None = Field(None, description="Thermal model YAML; null: the registered one.")
    aging: str | None = Field(None, description="Aging model YAML; null: the registered one.")
    tables_dir: str | None = Field(
        None, description="Folder of the lookup tables named in the electrical YAML; null: the registered ones."
    )
    eol_soh: float = Field(0.6, gt=0, lt=1, description="State of health at end of life (terminates the episode).")
    replacement_cost: float = Field(3000.0, ge=0, description="Battery replacement cost (EUR) of the degradation term.")


class RewardSection(ConfigSection):
    """Weights of the reward terms and their normalisation."""

    trading: float = Field(1.0, description="Weight of the trading income.")
    degradation: float = Field(1.0, description="Weight of the degradation cost.")
    clipping: float = Field(0.1, description="Weight of the clipping penalty.")
    normalize: bool = Field(
        True,
        description="Divide trading by max(max PV * max bid, max demand * max ask) and clipping by the largest "
        "net power of the data (the reference's default); degradation is left in EUR.",
    )


class FixesSection(ConfigSection):
    """Corrections of the reference's defects; null follows `fidelity` (on when corrected, off when upstream)."""

    celsius_lookup: bool | None = Field(None, description="Lookup tables in °C with bilinear interpolation (1).")
    capacity_fade: bool | None = Field(None, description="Coulomb counting against SoH * nominal capacity (2).")
    power_limits: bool | None = Field(None, description="The pack's current and power bounds limit the battery (3).")
    consistent_current: bool | None = Field(
        None, description="Current solved with the new terminal voltage; trade the energy the battery took (4)."
    )
    data_alignment: bool | None = Field(
        None, description="One modulus for every series; ambient temperature of the simulated hour (5)."
    )
    calendar_time: bool | None = Field(None, description="Calendar aging integrated with the current time (6).")
    standard_rainflow: bool | None = Field(
        None, description="Streaming ASTM rainflow keeping the residue; monotone SoH; cost on the SoH drop (7)."
    )
    thermal_core_state: bool | None = Field(None, description="Core temperature as the thermal state (8).")


class MicrogridConfig(EnvConfig):
    """Validated parameters of :class:`~gym4real.microgrid.env.MicrogridEnv`."""

    presets_package = "gym4real.microgrid"

    data: DataSection = DataSection()
    profiles: list[str] | None = Field(None, description="Demand columns to use; null: every column of the file.")
    profile_order: Literal["random", "sequential"] = Field(
        "random",
        description="How reset picks the profile without `options['profile']`: drawn from the seed, or in file "
        "order (reset(seed=s) restarts at profile s mod n).",
    )
    random_start: bool = Field(False, description="Start at a random hour of the data instead of the first.")
    random_battery_init: bool = Field(
        False, description="Draw the initial SoC, SoH and temperature within the pack's bounds."
    )
    decision_interval: int = Field(
        1, ge=1, description="Data steps per decision (1 h, 2 h, 4 h, ... with hourly data); the action is held."
    )
    max_steps: int | None = Field(
        None, ge=1, description="Data steps per episode; null: until the data is exhausted (rows - 1 from the start)."
    )
    observe_soh: bool = Field(False, description="Add the state of health to the observation (after `demand`).")
    battery: BatterySection = BatterySection()
    reward: RewardSection = RewardSection()
    fixes: FixesSection = FixesSection()
    upstream_seed: int = Field(
        42, description="Seed of the reference's construction-time RNG (profile and start draws, upstream only)."
    )

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if self.profiles is not None and not self.profiles:
            raise ValueError("profiles must list at least one demand column, or be null for all")
        if self.fidelity == "upstream" and self.data.generation is None:
            msg = (
                'fidelity="upstream" needs `data.generation`: the reference\'s dummy generation crashes (spec '
                'defect 11); name a generation file, or use fidelity="corrected" for the constant `data.dummy`'
            )
            raise ValueError(msg)
        return self

    def fix(self, name: str) -> bool:
        """Whether the correction ``name`` of :class:`FixesSection` applies."""
        value = getattr(self.fixes, name)
        return (self.fidelity == "corrected") if value is None else bool(value)
