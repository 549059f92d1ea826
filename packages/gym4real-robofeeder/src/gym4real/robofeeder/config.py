"""Configuration of the RoboFeeder environments.

Reference values: ../shared/data/reference-configs/robofeeder/configuration.yaml (simulator constants)
and the paper's appendix (reward shaping, T, number of objects). Each fix of a reference defect is a
``fixes.<name>`` switch: ``null`` follows ``fidelity`` (on when "corrected", off when "upstream").
"""

from __future__ import annotations

from typing import ClassVar, Literal, Self

from pydantic import Field, model_validator

from gym4real.core.config import ConfigSection, EnvConfig
from gym4real.core.errors import ConfigError


class ControllerSection(ConfigSection):
    """The timed pick controller (reference ``ACTION_*`` and gripper constants)."""

    long_pause: float = Field(
        0.025, gt=0, le=1.0, description="Simulated seconds between ticks at key waypoints (s, at most 1)."
    )
    short_pause: float = Field(
        0.016, gt=0, le=1.0, description="Simulated seconds between ordinary ticks (s, at most 1)."
    )
    delta_gripper: float = Field(
        0.00355, ge=0.0001, description="Finger command change per closing tick (m; at least 0.1 mm, so closing ends)."
    )
    open_gripper: float = Field(0.008, gt=0, le=0.008, description="Open finger command (m).")
    close_gripper: float = Field(0.00125, ge=0, description="Closing stops once the command is at most this (m).")


class SpawnSection(ConfigSection):
    """Where and how objects are placed at reset (normalised image coordinates in [-1, 1])."""

    x_range: tuple[float, float] = Field((-0.8, 0.8), description="Range of the normalised image x (u) of a spawn.")
    y_range: tuple[float, float] = Field(
        (-0.75, 0.1), description="Range of the normalised image y (v); the reference covers the upper part only."
    )
    min_distance: float = Field(0.27, ge=0, description="Minimum pairwise distance between spawns (normalised units).")
    height: float = Field(0.21, description="Drop height of an object's origin (m).")
    shuffle: bool = Field(True, description="Place objects at random (False: all at the MJCF pose, stacked).")
    upright: bool = Field(True, description="Yaw-only orientations; False draws an arbitrary quaternion.")


class WorkspaceSection(ConfigSection):
    """The reachable image window (reference ``X_LIMIT``, ``Y_DOWN``, ``Y_UP``, pixels of a 300-px image)."""

    x_limit: float = Field(0.0, ge=0, description="Margin (px) excluded at the left and right image borders.")
    y_down: float = Field(0.0, ge=0, description="Smallest reachable image row v (px).")
    y_up: float = Field(240.0, gt=0, description="Largest reachable image row v (px); farther rows are unreachable.")


class RewardSection(ConfigSection):
    """Shaping of a failed pick (paper appendix, Table 'RoboFeeder parameters')."""

    distance_weight: float = Field(0.85, ge=0, le=1, description="lambda: weight of the distance term.")
    delta_d: float = Field(0.012, gt=0, description="Distance (m) at which the distance term is one half.")
    delta_theta: float = Field(0.35, gt=0, description="Angle error (rad) at which the rotation term is one half.")


class FixesSection(ConfigSection):
    """Switches of the reference defects fixed by the corrected mode (null: follow `fidelity`)."""

    release_at_place: bool | None = Field(
        None,
        description="Defect 5: open the gripper at the place pose, move the placed object to the output tray "
        "and start the next plan from the arm's actual pose (upstream: held until the next pick, plans from zero).",
    )
    grasp_angle: bool | None = Field(
        None,
        description="Defect 6: true object yaw vs the planned gripper yaw, modulo pi (upstream: the "
        "quaternion-order slip with the 2.35 offset; also the planning orientation check).",
    )
    crop_clamp: bool | None = Field(
        None, description="Defect 9: clamp the crop window per axis (upstream: the mixed dx/dy check)."
    )
    centred_tool: bool | None = Field(
        None,
        description="IK on the point between the fingers with joint 6 held at the grasp angle (upstream: "
        "the left-finger origin with a free yaw, joint 6 then overwritten).",
    )
    unfeasible_targets: bool | None = Field(
        None,
        description="Defect 8: targets outside the reachable window or without an IK solution score -1 "
        "without moving the robot (upstream: dead code, every target is attempted).",
    )
    graspable_spawn: bool | None = Field(
        None,
        description="Paper appendix: spawn yaws are redrawn until the object can be grasped with joint 6 in "
        "[0, pi] (upstream: any yaw of the grid, about half of them cannot be picked).",
    )
    spawn_at_rest: bool | None = Field(
        None,
        description="Speed: spawn objects in their resting pose and settle briefly (upstream: drop from "
        "`spawn.height` and settle `settle_steps`).",
    )
    settle_until_rest: bool | None = Field(
        None, description="Speed: stop settling once every object is at rest (upstream: fixed step counts)."
    )
    sleep: bool | None = Field(
        None, description="Speed: MuJoCo's sleeping of bodies at rest (woken by any contact; upstream: off)."
    )


FIX_NAMES: tuple[str, ...] = tuple(FixesSection.model_fields)


class RoboFeederConfig(EnvConfig):
    """Parameters shared by the RoboFeeder environments."""

    presets_package = "gym4real.robofeeder"

    image_size: int = Field(300, ge=64, le=1024, description="Camera image width = height (px).")
    n_objects: int = Field(1, ge=1, le=8, description="Objects in the bin.")
    max_steps: int = Field(2, ge=1, description="Steps (pick attempts) per episode, T.")
    crop_size: int = Field(50, ge=8, description="Side of an object crop (px).")
    spawn: SpawnSection = SpawnSection()
    controller: ControllerSection = ControllerSection()
    workspace: WorkspaceSection = WorkspaceSection()
    reward: RewardSection = RewardSection()
    settle_steps: int = Field(
        900, ge=0, le=10_000, description="Physics steps after spawning (upstream and at most; at most 10,000)."
    )
    post_pick_steps: int = Field(
        400, ge=0, le=10_000, description="Physics steps after a pick (upstream and at most; at most 10,000)."
    )
    success_point: tuple[float, float, float] = Field(
        (-0.19096066, 0.47406576, 0.52), description="World point (m) an object must end near for a successful pick."
    )
    success_radius: float = Field(0.12, gt=0, description="Success tolerance (m) around `success_point`.")
    detector: str = Field(
        "classical",
        description='Object detector: "classical" (OpenCV threshold + contours), "oracle" (true poses projected '
        "through the camera) or the path of an ONNX detector with the TF-OD layout.",
    )
    detector_threshold: int = Field(150, ge=1, le=254, description="Gray level (0-255) above which a pixel is bright.")
    detector_min_area: int = Field(20, ge=1, description="Smallest blob (px) the classical detector keeps.")
    render_effects: bool = Field(False, description="Render shadows, reflections and the skybox.")
    render_camera: str = Field("top_down", description='Camera of `render()` ("top_down" or "angled_side_view").')
    fixes: FixesSection = FixesSection()

    def fix(self, name: str) -> bool:
        """Whether the fix ``name`` is on (its switch, or the fidelity when the switch is null)."""
        if name not in FIX_NAMES:
            raise ConfigError(f"unknown fix `{name}`; expected one of {list(FIX_NAMES)}")
        value = getattr(self.fixes, name)
        return self.fidelity == "corrected" if value is None else bool(value)

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        for name, (lo, hi) in (("spawn.x_range", self.spawn.x_range), ("spawn.y_range", self.spawn.y_range)):
            if not -1.0 <= lo <= hi <= 1.0:
                raise ValueError(f"{name} must satisfy -1 <= low <= high <= 1, got ({lo}, {hi})")
        if self.crop_size > self.image_size:
            raise ValueError(f"crop_size ({self.crop_size}) must not exceed image_size ({self.image_size})")
        if self.render_camera not in ("top_down", "angled_side_view", "angled_side_view_old"):
            raise ValueError(f"render_camera `{self.render_camera}` is not a camera of the scene")
        c = self.controller
        if c.close_gripper >= c.open_gripper:
            raise ValueError("controller.close_gripper must be below controller.open_gripper")
        return self


class PickingConfig(RoboFeederConfig):
    """Validated parameters of the picking environments (``picking-v0`` crop, ``picking-v1`` full image)."""


class PlanningConfig(RoboFeederConfig):
    """Validated parameters of the planning environment."""

    presets_folder: ClassVar[str] = "presets/planning"
    preset_aliases: ClassVar[dict[str, str]] = {"planning": "default", "planning_test": "test"}

    n_objects: int = Field(3, ge=1, le=8, description="Objects in the bin.")
    max_steps: int = Field(5, ge=1, description="Steps per episode, T.")
    n_crops: int = Field(3, ge=1, le=8, description="Object crops in the observation, N (the action space is N + 1).")
    picking_agent: Literal["pretrained", "oracle"] | str = Field(
        "pretrained",
        description='Low-level picking policy: "pretrained" (the reference ONNX agent), "oracle", or the path '
        "of another ONNX picking agent with the same input and output layout.",
    )
    agent_mode: Literal["mean", "sample"] | None = Field(
        None,
        description="Pretrained agent actions: the deterministic mean, or a sample with its own std drawn "
        "from the env's RNG; null: mean when corrected, sample when upstream.",
    )
    clip_agent_actions: bool | None = Field(
        None, description="Clip the agent's actions to [-1, 1] (the reference does not); null: follow fidelity."
    )
