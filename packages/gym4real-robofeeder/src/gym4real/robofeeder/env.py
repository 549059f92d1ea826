"""The RoboFeeder picking environments (``picking-v0`` crop, ``picking-v1`` full image) and their base."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.core import RenderFrame

from gym4real.core.actions import box_action
from gym4real.robofeeder.config import PickingConfig, RoboFeederConfig
from gym4real.robofeeder.detection import Detection, Detector, crop, make_detector
from gym4real.robofeeder.portable_math import dot, norm
from gym4real.robofeeder.rendering import grayscale
from gym4real.robofeeder.reward import angle_error_mod_pi, reference_angle_error, shaped
from gym4real.robofeeder.simulator import PickOutcome, Simulator, tilt_of, yaw_of

#: Grasp point of the oracle in the object frame: the wall centre, 3 mm to its outer side (m).
ORACLE_OFFSET = np.array([0.0, -0.003])
#: An object lies flat when its z axis is within this angle of the vertical (rad).
FLAT_TILT = 0.35
#: Frames per second of ``render_mode="rgb_array_list"``: a pick's controller ticks, about 4x slower than simulated.
PICK_FPS = 15


class RoboFeederBaseEnv(gym.Env[np.ndarray, Any]):
    """Shared machinery: config, simulator, detector, rendering, seeding, pickling and the oracle.

    ``render_mode="rgb_array"``: the frame of the render camera after each step (one per pick).
    ``render_mode="rgb_array_list"``: every frame since the last ``render()``: after ``reset``, the start;
    after a step, the arm at each tick of its pick (robot shown), then the frame the step ends on.
    """

    metadata = {"render_modes": ["rgb_array", "rgb_array_list"], "render_fps": 2}
    config_class: ClassVar[type[RoboFeederConfig]] = PickingConfig

    def __init__(
        self,
        config: RoboFeederConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        self._init_args = (config, preset, render_mode, overrides)
        self.config = self.config_class.build(config, preset, **overrides)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            msg = f"`render_mode` must be one of {self.metadata['render_modes']} or None, not {render_mode!r}"
            raise ValueError(msg)
        self.render_mode = render_mode
        if render_mode == "rgb_array_list":
            self.metadata = {**self.metadata, "render_fps": PICK_FPS}
        self._frames: list[RenderFrame] = []
        self.sim = Simulator(self.config)
        self.detector: Detector = make_detector(
            self.config.detector, self.config.detector_threshold, self.config.detector_min_area, self._true_pixels
        )
        self.size = self.config.image_size
        self.crop_size = self.config.crop_size
        self.max_steps = self.config.max_steps
        self._frame = np.zeros((self.size, self.size, 3), np.uint8)
        self._steps = 0

    # ------------------------------------------------------------------ gymnasium plumbing
    def __getstate__(self) -> dict[str, Any]:
        return {"init_args": self._init_args}

    def __setstate__(self, state: dict[str, Any]) -> None:
        config, preset, render_mode, overrides = state["init_args"]
        self.__init__(config, preset=preset, render_mode=render_mode, **overrides)  # type: ignore[misc]

    def render(self) -> np.ndarray | list[RenderFrame] | None:
        """The colour view of `render_camera` (uint8, H x W x 3), or the frames since the last call.

        ``rgb_array``: the last frame; ``rgb_array_list``: the frames since the last call (a whole pick per step;
        at least one frame per step).
        """
        if self.render_mode == "rgb_array_list":
            frames, self._frames = self._frames, []
            return frames
        if self.render_mode != "rgb_array":
            return None
        return self._view()

    def _view(self) -> np.ndarray:
        if self.config.render_camera == "top_down":
            return self._frame.copy()
        return self.sim.render(self.config.render_camera)

    def _film(self) -> None:
        """Keep a frame of the arm mid-pick (``rgb_array_list``)."""
        self._frames.append(self.sim.render(self.config.render_camera, robot=True))

    def _pick(self, xy: np.ndarray, theta: float, pixel: np.ndarray) -> PickOutcome:
        """The simulator's pick, filmed tick by tick under ``render_mode="rgb_array_list"``."""
        return self.sim.pick(xy, theta, pixel, on_tick=self._film if self.render_mode == "rgb_array_list" else None)

    def close(self) -> None:
        """Free the renderer (its OpenGL context)."""
        if hasattr(self, "sim"):
            self.sim.close()

    # ------------------------------------------------------------------ helpers
    def _observe_frame(self) -> np.ndarray:
        self._frame = self.sim.render("top_down")
        if self.render_mode == "rgb_array_list":
            self._frames.append(self._view())
        return self._frame

    def _true_pixels(self) -> np.ndarray:
        """Pixel centres of the objects still in the bin (for the oracle detector)."""
        centres = self.sim.object_centres()[~self.sim.picked]
        plane = self.sim.camera.plane_height()
        centres[:, 2] = plane
        return self.sim.camera.world_to_pixel(centres)

    def _crop(self, frame: np.ndarray, detection: Detection) -> tuple[np.ndarray, np.ndarray]:
        return crop(frame, detection.box, self.crop_size, per_axis=self.config.fix("crop_clamp"))

    def _theta(self, a: float) -> float:
        return (float(a) + 1.0) * np.pi / 2.0

    def grasp_yaw_target(self, index: int) -> tuple[np.ndarray, float, bool]:
        """The oracle's grasp of object ``index``: world (x, y), joint-6 angle, and whether it is graspable.

        The grasp is the object's wall centre (site), 3 mm to its outer side, with the gripper x axis
        along the object x axis; graspable when that joint-6 angle lies in [0, pi] and the object is flat.
        """
        quat = self.sim.object_quats()[index]
        site = self.sim.site_positions()[index]
        psi = float(yaw_of(quat))
        rot = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
        xy = site[:2] + dot(rot, ORACLE_OFFSET)
        theta = self.sim.grasp_angle(xy, psi)
        ok = theta <= np.pi and float(tilt_of(quat)) < FLAT_TILT
        if not ok and theta > np.pi:
            theta -= np.pi  # the flipped grasp: the best the joint range allows
        return xy, float(np.clip(theta, 0.0, np.pi)), bool(ok)

    def graspable(self, index: int) -> bool:
        """Whether object ``index`` is still in the bin, flat, reachable and in a graspable yaw (corrected)."""
        if self.sim.picked[index]:
            return False
        xy, _, ok = self.grasp_yaw_target(index)
        pixel = self.sim.camera.world_to_pixel(np.array([xy[0], xy[1], self.sim.camera.plane_height()]))
        return ok and self.sim.reachable(pixel)

    def oracle_grasp(self, centre: np.ndarray) -> tuple[np.ndarray, float] | None:
        """Image point and joint-6 angle grasping the object left nearest the image point ``centre``."""
        left = [i for i in range(self.sim.n) if not self.sim.picked[i]]
        if not left:
            return None
        centre_xy = self.sim.camera.pixel_to_world(np.asarray(centre, dtype=float))
        sites = self.sim.site_positions()
        i = min(left, key=lambda k: float(norm(sites[k, :2] - centre_xy)))
        xy, theta, _ = self.grasp_yaw_target(i)
        pixel = self.sim.camera.world_to_pixel(np.array([xy[0], xy[1], self.sim.camera.plane_height()]))
        return pixel, theta

    def nearest_object(self, xy: np.ndarray, sites: np.ndarray | None = None) -> int:
        """Index of the object whose site is nearest to world ``xy`` (picked ones included, as the reference)."""
        sites = self.sim.site_positions() if sites is None else sites
        return int(np.argmin(norm(sites[:, :2] - np.asarray(xy)[None])))


class RoboFeederPickingEnv(RoboFeederBaseEnv):
    """RoboFeeder picking-v0: grasp a detected hinge from a 50x50 crop around it.

    ## Description

    A MuJoCo cell (Staubli TX2-60, parallel gripper, a bin of automotive hinges seen by a top-down camera,
    Gym4ReaL paper section 3 and appendix). The agent chooses where in the crop, and at which wrist
    angle, to grasp; a scripted pick cycle (inverse kinematics to pre-pick, pick and place poses, a timed
    position controller) executes it; the pick succeeds if an object ends near the place point.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``: (dx, dy, theta~). Target pixel = crop centre + (dx, dy) * crop/2;
    joint-6 angle theta = (theta~ + 1) * pi / 2 in [0, pi]. Actions outside the box raise ``ValueError``.

    ## Observation Space

    ``Box(0, 1, (1, 50, 50), float32)``: grayscale crop around the best detection of the top-down frame
    (all zero when nothing is detected).

    ## Rewards

    Per step, scaled by 1/T: +1 on success; on failure -1 + lambda exp(-alpha_d d^2) +
    (1 - lambda) exp(-alpha_theta dtheta^2) (lambda 0.85, half values at d = 12 mm and dtheta = 0.35 rad;
    d from the target to the grasp site of the nearest object, -1 if that object was already picked);
    -1 for an unfeasible target (outside the reachable window or without an IK solution), which also
    sets ``info["cost"] = 1``. ``info["reward_components"]`` holds the scaled terms.

    ## Starting State

    ``n_objects`` (1) hinges placed uniformly in the spawn area (upper part of the image, at least 0.27
    normalised units apart), yaw from the reference's quaternion grid, settled on the bin floor.

    The arm reaches about 0.59 m from its axis with the tool pointing down (the pre-pick pose 25 cm above
    the part binds first): the image rows below v ~ 195-225 px (300-px image, depending on u) are out of
    reach in both modes. The spawn area lies within reach; in the corrected mode a spawn area reaching
    beyond raises ``ConfigError``. The ``placements`` reset option places objects anywhere (the reference's
    heat-map grid extends to v = 270 px, out of reach).

    ## Episode End

    Terminated when every object is picked; truncated after T = 2 attempts.

    ## Arguments

    ``config`` / ``preset`` ("default", "test") / keyword overrides of :class:`PickingConfig`
    (``fidelity``, ``n_objects``, ``detector``, ``fixes``, ...); ``render_mode="rgb_array"`` (a frame per
    step) or ``"rgb_array_list"`` (every tick of each pick).
    ``fidelity="upstream"`` reproduces the reference's behaviour; the corrected default fixes:
    seeding from ``reset(seed=)`` (positions and orientations), in-memory scene, per-instance controller,
    release at the place pose (``fixes.release_at_place``), true yaw error modulo pi
    (``fixes.grasp_angle``), per-axis crop clamping (``fixes.crop_clamp``), IK at the gripper centre
    with joint 6 held (``fixes.centred_tool``), unfeasible targets (``fixes.unfeasible_targets``),
    graspable spawn yaws as the paper states (``fixes.graspable_spawn``), and the speed options
    ``fixes.spawn_at_rest`` / ``fixes.settle_until_rest`` / ``fixes.sleep``. Always: a classical detector replaces the
    missing SSD network, terminated/truncated are distinct, the action is copied, ``info`` is filled.

    ## Version History

    * v0: Gym4ReaL 1.0 reference, re-implemented on MuJoCo 4.
    """

    config_class = PickingConfig
    reward_component_names = ("success", "failure", "distance", "rotation", "unfeasible")

    def __init__(
        self,
        config: PickingConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        super().__init__(config, preset=preset, render_mode=render_mode, **overrides)
        self.action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.observation_space = self._observation_space()
        self._centre = np.zeros(2)

    def _observation_space(self) -> spaces.Box:
        return spaces.Box(0.0, 1.0, (1, self.crop_size, self.crop_size), np.float32)

    def _observe(self) -> np.ndarray:
        frame = self._observe_frame()
        detections = self.detector.detect(frame)
        if not detections:
            centre = (self.size - 1) / 2.0 if self.config.fidelity == "corrected" else 0.0
            self._centre = np.array([centre, centre])
            return np.zeros((1, self.crop_size, self.crop_size), np.float32)
        patch, self._centre = self._crop(frame, detections[0])
        return patch[None]

    def _target_pixel(self, a: np.ndarray) -> np.ndarray:
        return self._centre + a[:2] * (self.crop_size / 2.0)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Spawn the objects and observe.

        Args:
            seed: Seeds ``np_random`` (positions and orientations).
            options: ``placements`` (N x 2 normalised image coordinates) and/or ``yaws`` (N, rad) to place
                the objects deterministically (used by the workspace heat map).
        """
        super().reset(seed=seed)
        options = options or {}
        self._frames = []
        self._spawn(options)
        self._steps = 0
        obs = self._observe()
        return obs, {"objects_left": int((~self.sim.picked).sum()), "crop_centre": self._centre.copy()}

    def _spawn(self, options: dict[str, Any]) -> None:
        placements = options.get("placements")
        yaws = options.get("yaws")
        self.sim.reset(
            self.np_random,
            placements=None if placements is None else np.asarray(placements, float),
            yaws=None if yaws is None else np.asarray(yaws, float),
            graspable_only=self.config.fix("graspable_spawn"),
        )

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Attempt one pick at the grasp point and angle of ``action``."""
        a = box_action(action, self.action_space, "grasp point (x, y) and angle, each in [-1, 1]", tolerance=1e-6)
        pixel = self._target_pixel(a)
        theta = self._theta(a[2])
        xy = self.sim.camera.pixel_to_world(pixel)
        outcome = self._pick(xy, theta, pixel)
        components, info = self._reward(outcome, xy)
        self._steps += 1
        obs = self._observe()
        reward = float(sum(components.values()))
        terminated = bool(self.sim.picked.all())
        truncated = bool(self._steps >= self.max_steps and not terminated)
        info.update(target_pixel=pixel, reward_components=components, crop_centre=self._centre.copy())
        return obs, reward, terminated, truncated, info

    def _reward(self, outcome: PickOutcome, xy: np.ndarray) -> tuple[dict[str, float], dict[str, Any]]:
        scale = 1.0 / self.max_steps
        comps = dict.fromkeys(self.reward_component_names, 0.0)
        i = self.nearest_object(xy, outcome.initial_sites)
        distance = float(norm(outcome.initial_sites[i, :2] - xy))
        if self.config.fix("grasp_angle"):
            angle_error = angle_error_mod_pi(outcome.gripper_yaw, float(yaw_of(outcome.initial_quats[i])))
        else:
            angle_error = reference_angle_error(outcome.initial_quats[i], outcome.theta)
        if not outcome.feasible:
            comps["unfeasible"] = -scale
        elif outcome.success:
            comps["success"] = scale
        elif self.sim.picked[i] and outcome.picked != i:
            comps["failure"] = -scale
        else:
            base, dist_term, rot_term = shaped(distance, angle_error, self.config.reward)
            comps.update(failure=base * scale, distance=dist_term * scale, rotation=rot_term * scale)
        info = {
            "success": bool(outcome.success),
            "feasible": bool(outcome.feasible),
            "cost": 0.0 if outcome.feasible else 1.0,
            "target_world": outcome.target.copy(),
            "theta": outcome.theta,
            "distance": distance,
            "angle_error": angle_error,
            "nearest_object": i,
            "objects_picked": int(self.sim.picked.sum()),
            "objects_left": int((~self.sim.picked).sum()),
        }
        return comps, info

    # ------------------------------------------------------------------ oracle
    def oracle_action(self) -> np.ndarray:
        """The action grasping the object nearest the crop centre at its true grasp point and yaw."""
        grasp = self.oracle_grasp(self._centre)
        if grasp is None:
            return np.zeros(3, np.float32)
        pixel, theta = grasp
        return np.clip(np.append(self._action_xy(pixel), theta / (np.pi / 2.0) - 1.0), -1.0, 1.0).astype(np.float32)

    def _action_xy(self, pixel: np.ndarray) -> np.ndarray:
        return (pixel - self._centre) / (self.crop_size / 2.0)


class RoboFeederPickingImageEnv(RoboFeederPickingEnv):
    """RoboFeeder picking-v1: grasp a hinge seen in the full 300x300 top-down image.

    ## Description

    As :class:`RoboFeederPickingEnv` (picking-v0) without the detector: the agent sees the whole frame.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``: (x~, y~, theta~). Target pixel = (x~, y~ + 1) * W/2 (whole image);
    theta = (theta~ + 1) * pi / 2.

    ## Observation Space

    ``Box(0, 1, (1, 300, 300), float32)``: the grayscale top-down frame.

    ## Rewards

    As picking-v0 (+1, shaped failure, -1 unfeasible; all scaled by 1/T).

    ## Starting State

    As picking-v0.

    ## Episode End

    Terminated when every object is picked; truncated after T = 2 attempts.

    ## Arguments

    As picking-v0 (:class:`PickingConfig`); the detector is not used. The reference mutates the
    caller's action array; here it is copied.

    ## Version History

    * v1: Gym4ReaL 1.0 reference, re-implemented on MuJoCo 4.
    """

    def _observation_space(self) -> spaces.Box:
        return spaces.Box(0.0, 1.0, (1, self.size, self.size), np.float32)

    def _observe(self) -> np.ndarray:
        self._centre = np.array([(self.size - 1) / 2.0] * 2)
        return grayscale(self._observe_frame())[None]

    def _target_pixel(self, a: np.ndarray) -> np.ndarray:
        return (a[:2] + 1.0) * (self.size / 2.0)

    def _action_xy(self, pixel: np.ndarray) -> np.ndarray:
        return pixel / (self.size / 2.0) - 1.0
