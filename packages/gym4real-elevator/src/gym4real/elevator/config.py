"""Configuration of ElevatorEnv (reference values: ../shared/data/reference-configs/elevator/world.yaml)."""

from __future__ import annotations

from typing import Self

from pydantic import Field, model_validator

from gym4real.core.config import ConfigSection, EnvConfig


class ElevatorSection(ConfigSection):
    """The building and the cabin."""

    min_floor: int = Field(0, ge=0, description="Lowest floor.")
    max_floor: int = Field(4, ge=1, le=200, description="Highest floor (at most 200: the tallest towers have ~160).")
    max_capacity: int = Field(4, ge=1, le=100, description="Passengers the cabin holds (at most 100).")
    movement_speed: float = Field(
        3.0, ge=0.1, le=25.0, description="Metres travelled per step (one second); 0.1 to 25 m/s (the fastest lifts)."
    )
    floor_height: float = Field(
        6.0, gt=0, le=20.0, description="Metres between floors (at most 20); a multiple of the speed."
    )


class FloorsSection(ConfigSection):
    """The arrival processes."""

    max_arrivals: int = Field(2, ge=1, le=100, description="Arrivals kept per floor per second (at most 100).")
    max_queue_length: int = Field(
        3, ge=1, le=1000, description="Waiting passengers per floor (at most 1000); more arrivals balk."
    )
    lambda_min: float = Field(0.01, ge=0, le=100, description="Lower bound of the per-floor Poisson rate (1/s).")
    lambda_max: float = Field(
        0.1, ge=0, le=100, description="Upper bound of the per-floor Poisson rate (1/s, at most 100 people a second)."
    )
    seed: int = Field(
        42, description="Arrival seed of the upstream mode (the reference evaluates with 1234); unused when corrected."
    )


class ElevatorConfig(EnvConfig):
    """Validated parameters of :class:`~gym4real.elevator.env.ElevatorEnv`."""

    presets_package = "gym4real.elevator"

    elevator: ElevatorSection = ElevatorSection()
    floors: FloorsSection = FloorsSection()
    duration: int = Field(3600, ge=1, le=86_400, description="Steps (seconds) per episode, at most one day.")
    goal_floor: int = Field(0, ge=0, description="Destination of every passenger.")
    init_elevator_pos: float | None = Field(
        None, ge=0, description="Initial height (m), a multiple of the speed; null draws a position uniformly."
    )
    reward_coeff: float = Field(10.0, ge=0, description="Reward per delivered passenger (beta of the paper).")
    waiting_penalty_on_delivery: bool = Field(
        False, description="Also charge the waiting penalty in steps that deliver (the reference does not)."
    )

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        e, f = self.elevator, self.floors
        steps = e.floor_height / e.movement_speed
        if abs(steps - round(steps)) > 1e-9:
            raise ValueError(f"elevator.floor_height ({e.floor_height}) must be a multiple of movement_speed")
        if e.max_floor <= e.min_floor:
            raise ValueError("elevator.max_floor must be above elevator.min_floor")
        if not e.min_floor <= self.goal_floor <= e.max_floor:
            raise ValueError(f"goal_floor must lie in [{e.min_floor}, {e.max_floor}]")
        if f.lambda_max < f.lambda_min:
            raise ValueError("floors.lambda_max must not be below floors.lambda_min")
        top = e.floor_height * (e.max_floor - e.min_floor)
        if self.init_elevator_pos is not None:
            units = self.init_elevator_pos / e.movement_speed
            if self.init_elevator_pos > top or abs(units - round(units)) > 1e-9:
                raise ValueError(f"init_elevator_pos must be a multiple of movement_speed in [0, {top}]")
        return self
