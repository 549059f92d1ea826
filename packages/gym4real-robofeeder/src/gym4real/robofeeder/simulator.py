"""The robot cell: spawn, the scripted pick cycle with its timed controller, success test, camera.

One :class:`Simulator` per env instance owns its model copy, its data, its IK scratch data and its
renderer; nothing is process-global (the reference's ``mjcb_control`` callback, defect 4, becomes the
explicit tick loop of :meth:`Simulator.pick`, with the reference's tick timings).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gym4real.core.errors import ConfigError
from gym4real.core.install_hint import require
from gym4real.robofeeder._gl import mujoco
from gym4real.robofeeder.camera import CameraModel
from gym4real.robofeeder.config import RoboFeederConfig
from gym4real.robofeeder.kinematics import LEFT_FINGER_AXIS, LEFT_FINGER_TOOL, ArmKinematics, IKResult
from gym4real.robofeeder.portable_math import arccos, atan2, dot, norm
from gym4real.robofeeder.rendering import LazyRenderer
from gym4real.robofeeder.scene import build_model

#: Robot base height (m): IK targets of the reference are in the base frame.
BASE_Z = 0.11
PICK_Z = 0.11  # base frame
PRE_PICK_LIFT = 0.25
PLACE = np.array([-0.0882, 0.4929, 0.4596])  # base frame
KEY_TICKS = (5, 10, 15)
CLOSE_AFTER_TICK = 9
ARM_TICKS = 20
EXTRA_TICKS = 5
SAMPLES_PER_SEGMENT = 5
#: The point of the flange frame the corrected IK places: between the finger origins.
CENTRE_TOOL = np.array([0.0, 0.0, 0.075])
#: Top of the bin floor `PickBoxPlane` (m, world).
PLANE_TOP = 0.18535
#: Output tray: placed objects rest on the floor here, out of the camera's view (corrected mode).
TRAY = np.array([0.45, -0.45])
#: An object is at rest below these speeds (m/s, rad/s).
REST_LINEAR = 5e-3
REST_ANGULAR = 0.1
SETTLE_CHUNK = 20
#: An object's grasp site lies up to this far (m) from its body origin: the reach check of the spawn area
#: looks this much farther from the robot's axis than the area's corners.
SITE_REACH_MARGIN = 0.02
#: Graspable spawns keep the grasp angle this far (rad) inside [0, pi].
GRASP_MARGIN = 0.1
MIN_SETTLE = 40


@dataclass
class PickOutcome:
    """What a pick attempt did.

    Attributes:
        feasible: Whether the target was attempted (inside the reachable window, IK solved).
        success: Whether an object ended near the success point.
        picked: Index of the object picked, or None.
        target: Commanded world point (x, y, z) of the tool.
        theta: Commanded joint-6 angle (rad).
        gripper_yaw: World yaw of the flange x axis at the planned pick pose (rad).
        ik_error: Position error of the pick-pose IK (m).
        steps: Physics steps simulated.
        initial_sites: World positions of the object sites before the pick (N x 3).
        initial_quats: Object quaternions (w, x, y, z) before the pick (N x 4).
    """

    feasible: bool
    success: bool
    picked: int | None
    target: np.ndarray
    theta: float
    gripper_yaw: float = float("nan")
    ik_error: float = float("nan")
    steps: int = 0
    initial_sites: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    initial_quats: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))


def yaw_of(quat: np.ndarray) -> np.ndarray:
    """World yaw (rad) of the body x axis for quaternion(s) (w, x, y, z); shape (..., 4) -> (...)."""
    w, x, y, z = np.moveaxis(np.asarray(quat, dtype=float), -1, 0)
    return atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def tilt_of(quat: np.ndarray) -> np.ndarray:
    """Angle (rad) between the body z axis and the world vertical for quaternion(s) (w, x, y, z)."""
    w, x, y, z = np.moveaxis(np.asarray(quat, dtype=float), -1, 0)
    norm2 = w * w + x * x + y * y + z * z
    zz = 1.0 - 2.0 * (x * x + y * y) / np.where(norm2 > 0, norm2, 1.0)
    return arccos(np.clip(zz, -1.0, 1.0))


def footprint_centre(model: mujoco.MjModel, resolution: float = 1e-4) -> np.ndarray:
    """Centroid of an object's silhouette seen from above, in its body frame (z = 0).

    The part's visual mesh is rasterised on a 0.1 mm grid.
    """
    cv2 = require("cv2", "gym4real-robofeeder", "opencv-python-headless")
    g = model.geom("obj0").id
    mesh = model.geom_dataid[g]
    verts = model.mesh_vert[model.mesh_vertadr[mesh] : model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
    faces = model.mesh_face[model.mesh_faceadr[mesh] : model.mesh_faceadr[mesh] + model.mesh_facenum[mesh]]
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, model.geom_quat[g])
    body = dot(verts, rot.reshape(3, 3).T) + model.geom_pos[g]
    half = float(np.abs(body[:, :2]).max()) + 1e-3
    cells = int(np.ceil(2 * half / resolution))
    mask = np.zeros((cells, cells), np.uint8)
    for tri in np.round((body[faces][:, :, :2] + half) / resolution).astype(np.int32):
        cv2.fillConvexPoly(mask, tri, 1)
    ys, xs = np.nonzero(mask)
    return np.array([xs.mean() * resolution - half, ys.mean() * resolution - half, 0.0])


@functools.lru_cache(maxsize=8)
def _rest_pose(n_objects: int, data_dir: str | None) -> tuple[float, tuple[float, ...]]:
    """Height and body tilt quaternion of an object lying on the bin floor (found once by dropping one)."""
    model = build_model(n_objects, data_dir)
    data = mujoco.MjData(model)
    for i in range(n_objects):
        data.qpos[7 * i : 7 * i + 7] = [-0.30 - 0.05 * i, 0.40 - 0.05 * i, 0.21, 1.0, 0.0, 0.0, 0.0]
    mujoco.mj_step(model, data, nstep=1200)
    q = data.qpos[3:7].copy()
    yaw = float(yaw_of(q))
    half = np.array([math.cos(-yaw / 2), 0.0, 0.0, math.sin(-yaw / 2)])
    tilt = np.zeros(4)
    mujoco.mju_mulQuat(tilt, half, q)
    return float(data.qpos[2]), tuple(float(v) for v in tilt / norm(tilt))


class Simulator:
    """The RoboFeeder cell of one environment instance.

    Args:
        config: The environment configuration.
    """

    def __init__(self, config: RoboFeederConfig) -> None:
        self.config = config
        self.n = config.n_objects
        self.model = build_model(self.n, config.data_dir)
        if config.fix("sleep"):
            self.model.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.dt = float(m.opt.timestep)
        self.object_bodies = np.array([m.body(f"object{i}").id for i in range(self.n)])
        self.object_qadr = np.array([m.jnt_qposadr[m.body_jntadr[b]] for b in self.object_bodies])
        self.object_dofadr = np.array([m.jnt_dofadr[m.body_jntadr[b]] for b in self.object_bodies])
        self.object_sites = np.array([m.site(f"site_obj{i}").id for i in range(self.n)])
        centred = config.fix("centred_tool")
        self.kin = ArmKinematics(m, CENTRE_TOOL) if centred else ArmKinematics(m, LEFT_FINGER_TOOL, LEFT_FINGER_AXIS)
        self.arm_qadr = self.kin.qadr
        self.picked = np.zeros(self.n, dtype=bool)
        self.last_q = np.zeros(6)
        mujoco.mj_forward(m, self.data)
        cam = m.camera("top_down").id
        self.camera = CameraModel.from_pose(
            self.data.cam_xpos[cam],
            self.data.cam_xmat[cam].reshape(3, 3),
            float(m.cam_fovy[cam]),
            config.image_size,
            config.image_size,
        )
        centre = self.camera.pixel_to_world(np.array([(config.image_size - 1) / 2.0] * 2))
        self.home_q = self.kin.solve(
            np.array([centre[0], centre[1], BASE_Z + PICK_Z + PRE_PICK_LIFT]), np.zeros(6), fixed_j6=np.pi / 2
        ).q
        self._yaw_cache: dict[tuple[float, float], float] = {}
        self._footprint: np.ndarray | None = None
        self.renderer = LazyRenderer(m, config.image_size, config.image_size, effects=config.render_effects)
        self.physics_steps = 0
        if config.fix("unfeasible_targets") and config.spawn.shuffle:
            self._check_spawn_within_reach()

    def _check_spawn_within_reach(self) -> None:
        """Refuse a spawn area reaching beyond the arm: objects spawned there could never be picked.

        The arm reaches about 0.59 m from its axis with the tool pointing down (the pre-pick pose 25 cm above
        the part binds first), image rows v > ~200-230 px; reach depends on the distance from the axis only,
        so the corners of the spawn area are the points to check.
        """
        s = self.config.spawn
        for x in s.x_range:
            for y in s.y_range:
                pixel = (np.array([x, y]) + 1.0) * (self.config.image_size / 2.0)
                xy = self.camera.pixel_to_world(pixel)
                site = xy * (1.0 + SITE_REACH_MARGIN / float(norm(xy)))
                if not self.arm_reaches(site):
                    msg = (
                        f"the spawn area reaches image point {pixel.round(1).tolist()} (normalised ({x}, {y})), "
                        f"{float(norm(xy)):.3f} m from the robot's axis, where the arm cannot pick with the tool "
                        "pointing down (its reach ends near 0.59 m, image rows v > ~195-225 px): narrow "
                        "`spawn.x_range` / `spawn.y_range` (the default (-0.8, 0.8) x (-0.75, 0.1) is within reach), "
                        "or set `fixes.unfeasible_targets: false` to spawn there anyway"
                    )
                    raise ConfigError(msg)

    # ------------------------------------------------------------------ state
    def close(self) -> None:
        """Free the renderer."""
        self.renderer.close()

    def render(self, camera: str = "top_down", robot: bool = False) -> np.ndarray:
        """RGB frame (uint8, H x W x 3) of ``camera`` (``robot``: with the arm, which the observation hides)."""
        mujoco.mj_forward(self.model, self.data)
        return self.renderer.render(self.data, camera, robot)

    def object_positions(self) -> np.ndarray:
        """Body origins of the objects (N x 3, world)."""
        return np.array([self.data.qpos[a : a + 3] for a in self.object_qadr])

    def object_quats(self) -> np.ndarray:
        """Object quaternions (N x 4, w x y z, as stored)."""
        return np.array([self.data.qpos[a + 3 : a + 7] for a in self.object_qadr])

    def site_positions(self) -> np.ndarray:
        """World positions of the object grasp sites (N x 3), after kinematics."""
        mujoco.mj_kinematics(self.model, self.data)
        return self.data.site_xpos[self.object_sites].copy()

    def object_centres(self) -> np.ndarray:
        """World centres of the objects' silhouettes seen from above (N x 3, at the body origin's height)."""
        mujoco.mj_kinematics(self.model, self.data)
        if self._footprint is None:
            self._footprint = footprint_centre(self.model)
        local = self._footprint
        out = []
        for b in self.object_bodies:
            out.append(self.data.xpos[b] + dot(self.data.xmat[b].reshape(3, 3), local))
        return np.array(out)

    # ------------------------------------------------------------------ reset
    def _step(self, n: int) -> None:
        if n > 0:
            mujoco.mj_step(self.model, self.data, nstep=n)
            self.physics_steps += n

    def _at_rest(self) -> bool:
        v = self.data.qvel
        for adr, picked in zip(self.object_dofadr, self.picked, strict=True):
            if picked:
                continue
            if np.abs(v[adr : adr + 3]).max() > REST_LINEAR or np.abs(v[adr + 3 : adr + 6]).max() > REST_ANGULAR:
                return False
        return True

    def settle(self, max_steps: int) -> None:
        """Step the physics ``max_steps`` times, or until every object is at rest (corrected mode)."""
        if not self.config.fix("settle_until_rest"):
            self._step(max_steps)
            return
        done = 0
        while done < max_steps:
            n = min(SETTLE_CHUNK, max_steps - done)
            self._step(n)
            done += n
            if done >= MIN_SETTLE and self._at_rest():
                break

    def spawn_points(self, rng: np.random.Generator) -> np.ndarray:
        """Normalised image coordinates (N x 2) with pairwise distances of at least ``spawn.min_distance``."""
        s = self.config.spawn
        for _ in range(10_000):
            xy = np.column_stack([rng.uniform(*s.x_range, self.n), rng.uniform(*s.y_range, self.n)])
            if self.n == 1:
                return xy
            gaps = norm(xy[:, None] - xy[None])[np.triu_indices(self.n, 1)]
            if (gaps >= s.min_distance).all():
                return xy
        msg = f"cannot place {self.n} objects `spawn.min_distance` apart in the spawn area; lower `n_objects`"
        raise ValueError(msg)

    def reset(
        self,
        rng: np.random.Generator,
        placements: np.ndarray | None = None,
        yaws: np.ndarray | None = None,
        graspable_only: bool = False,
    ) -> None:
        """Reset the cell and spawn the objects.

        Args:
            rng: The env's generator (positions and orientations).
            placements: Optional normalised image coordinates (N x 2) instead of random ones.
            yaws: Optional object yaws (rad) instead of random orientations.
            graspable_only: Redraw each yaw until the object can be grasped with joint 6 in [0, pi].
        """
        m, d, cfg = self.model, self.data, self.config
        mujoco.mj_resetData(m, d)
        self.picked[:] = False
        self.last_q = np.zeros(6)
        at_rest = cfg.fix("spawn_at_rest") and cfg.spawn.upright
        if cfg.spawn.shuffle or placements is not None:
            xy = self.spawn_points(rng) if placements is None else np.asarray(placements, dtype=float)
            world = self.camera.pixel_to_world((xy + 1.0) * (cfg.image_size / 2.0))
            rest_z, tilt = _rest_pose(self.n, cfg.data_dir) if at_rest else (cfg.spawn.height, (1.0, 0, 0, 0))
            for i, adr in enumerate(self.object_qadr):
                if yaws is not None:
                    quat = np.array([math.cos(yaws[i] / 2), 0.0, 0.0, math.sin(yaws[i] / 2)])
                else:
                    quat = self._draw_quat(rng, world[i] if graspable_only else None)
                if at_rest:
                    rested = np.zeros(4)
                    mujoco.mju_mulQuat(rested, quat, np.asarray(tilt))
                    quat = rested
                d.qpos[adr : adr + 7] = [world[i, 0], world[i, 1], rest_z, *quat]
        mujoco.mj_forward(m, d)
        steps = min(cfg.settle_steps, MIN_SETTLE) if at_rest and cfg.spawn.shuffle else cfg.settle_steps
        self.settle(steps)
        mujoco.mj_step(m, d)  # the reference's get_state() steps once before rendering
        self.physics_steps += 1

    def _draw_quat(self, rng: np.random.Generator, graspable_at: np.ndarray | None) -> np.ndarray:
        """The reference's orientation draw: 4 values of the grid -1, -0.8, ..., 1 (qw := v0, qz := v1 if upright)."""
        grid = np.arange(-1.0, 1.1, 0.2)
        for _ in range(200):
            v = rng.choice(grid, 4)
            quat = np.array([v[0], 0.0, 0.0, v[1]]) if self.config.spawn.upright else v
            length = float(norm(quat))
            quat = quat / length if length > 1e-9 else np.array([1.0, 0.0, 0.0, 0.0])
            if graspable_at is None:
                return quat
            theta = self.grasp_angle(graspable_at, float(yaw_of(quat)))
            if GRASP_MARGIN <= theta <= np.pi - GRASP_MARGIN:
                return quat
        return quat

    # ------------------------------------------------------------------ picking
    def reachable(self, pixel: np.ndarray) -> bool:
        """Whether an image point lies in the reachable window (``workspace``, scaled to the image size)."""
        w = self.config.workspace
        scale = self.config.image_size / 300.0
        u, v = float(pixel[0]), float(pixel[1])
        size = self.config.image_size
        return bool(w.x_limit * scale <= u <= size - 1 - w.x_limit * scale and w.y_down * scale <= v <= w.y_up * scale)

    def arm_reaches(self, xy: np.ndarray) -> bool:
        """Whether the pick script's pre-pick, pick and place poses for world ``xy`` have IK solutions."""
        return self.plan(np.asarray(xy, dtype=float), np.pi / 2)[3]

    def _pick_poses(self, pick: np.ndarray, start: np.ndarray, theta: float) -> tuple[IKResult, IKResult]:
        """IK of the pre-pick and pick poses above and at world point ``pick``, planning from joints ``start``.

        Corrected: joint 6 held at ``theta``, seeded above the bin centre first (the arm straight up is
        singular for a downward tool). Upstream: the reference's free-yaw IK seeded with ``start`` (always
        zero there), the pick pose seeded with the pre-pick pose, no fallback.
        """
        pre = pick + np.array([0.0, 0.0, PRE_PICK_LIFT])
        if self.config.fix("centred_tool"):
            wp0 = self.kin.solve_from(pre, [self.home_q, start], fixed_j6=theta)
            return wp0, self.kin.solve_from(pick, [wp0.q, self.home_q], fixed_j6=theta)
        wp0 = self.kin.solve_free_yaw(pre, start)
        return wp0, self.kin.solve_free_yaw(pick, wp0.q)

    def plan(self, xy: np.ndarray, theta: float) -> tuple[np.ndarray, float, float, bool]:
        """The reference's 20 waypoints (joints 1-6) to pre-pick, pick, retreat and place.

        Returns:
            (plan (20 x 6), pick-pose IK error (m), planned gripper yaw (rad), whether every IK converged).
        """
        pick = np.array([xy[0], xy[1], BASE_Z + PICK_Z])
        place = PLACE + np.array([0.0, 0.0, BASE_Z])
        start = self.last_q.copy()
        wp0, wp1 = self._pick_poses(pick, start, theta)
        if self.config.fix("centred_tool"):
            wp3 = self.kin.solve_from(place, [wp0.q, self.home_q], fixed_j6=theta)
        else:
            wp3 = self.kin.solve_free_yaw(place, wp0.q)
        gripper_yaw = self._gripper_yaw(wp1, theta)
        s = np.linspace(0.0, 1.0, SAMPLES_PER_SEGMENT)[:, None]
        segments = [(start, wp0.q), (wp0.q, wp1.q), (wp1.q, wp0.q), (wp0.q, wp3.q)]
        rows = np.vstack([a + s * (b - a) for a, b in segments])
        ok = wp0.ok and wp1.ok and wp3.ok
        return rows, wp1.position_error, gripper_yaw, ok

    def _gripper_yaw(self, pick_pose: IKResult, theta: float) -> float:
        """World yaw (rad) of the flange x axis at the pick pose with joint 6 at ``theta``."""
        _, rot = self.kin.forward(np.concatenate([pick_pose.q[:5], [theta]]))
        return math.atan2(rot[1, 0], rot[0, 0])

    def grasp_angle(self, xy: np.ndarray, yaw: float) -> float:
        """Joint-6 angle (rad, in [0, 2 pi)) aligning the gripper x axis with ``yaw`` at a pick at world ``xy``.

        At the planned pick pose the gripper yaw is ``c - theta`` (joint 6 turns about the downward tool
        axis), with ``c`` the yaw at theta = 0; angles above pi are outside joint 6's control range.
        """
        key = (round(float(xy[0]), 4), round(float(xy[1]), 4))
        c = self._yaw_cache.get(key)
        if c is None:
            pick = np.array([key[0], key[1], BASE_Z + PICK_Z])  # a pure function of the cache key
            start = self.home_q if self.config.fix("centred_tool") else np.zeros(6)
            _, wp1 = self._pick_poses(pick, start, 0.0)
            _, rot = self.kin.forward(np.concatenate([wp1.q[:5], [0.0]]))
            c = math.atan2(rot[1, 0], rot[0, 0])
            if len(self._yaw_cache) > 4096:
                self._yaw_cache.clear()
            self._yaw_cache[key] = c
        return float((c - yaw) % (2.0 * np.pi))

    def _run_controller(self, plan: np.ndarray, theta: float, on_tick: Callable[[], None] | None) -> np.ndarray:
        """Execute the plan with the reference's tick timings; return the object positions at the last tick.

        The reference's control callback runs inside ``mj_step`` before the integration: a tick at time t
        applies its command to the step from t, and the pick ends after the step of its last tick.
        ``on_tick`` is called as each tick fires (to film the pick).
        """
        c = self.config.controller
        d = self.data
        d.ctrl[6:8] = c.open_gripper
        d.ctrl[5] = theta
        gripper = c.open_gripper
        last_tick = 0.0  # the reference's `step_time` starts at zero: the first tick fires at the first step
        limit = c.short_pause
        tick = extra = 0
        closing = False
        while True:
            # advance to the first step at which `time - last_tick > limit` (as the reference's callback sees it)
            t = d.time
            n = 0
            while not t - last_tick > limit:
                t += self.dt
                n += 1
            self._step(n)
            last_tick = d.time
            if on_tick is not None:
                on_tick()
            if closing:
                gripper -= c.delta_gripper
                d.ctrl[6:8] = max(gripper, 0.0)
                if gripper <= c.close_gripper:
                    closing = False
                    limit = c.long_pause
            elif tick < ARM_TICKS:
                d.ctrl[0:5] = plan[tick][:5]
                limit = c.long_pause if tick in KEY_TICKS else c.short_pause
                if tick == CLOSE_AFTER_TICK:
                    closing = True
                tick += 1
            else:
                extra += 1
                if extra >= EXTRA_TICKS:
                    final = self.object_positions()
                    self._step(1)
                    return final

    def pick(
        self,
        xy: np.ndarray,
        theta: float,
        pixel: np.ndarray | None = None,
        on_tick: Callable[[], None] | None = None,
    ) -> PickOutcome:
        """Attempt to pick at world ``xy`` with joint 6 at ``theta``.

        Args:
            xy: Target (x, y) on the picking plane (m, world).
            theta: Joint-6 angle (rad), clamped to its control range [0, pi].
            pixel: The image point the target came from (for the reachable-window check).
            on_tick: Called at each tick of the pick's controller (to film it).
        """
        cfg = self.config
        theta = float(np.clip(theta, 0.0, np.pi))
        target = np.array([xy[0], xy[1], BASE_Z + PICK_Z])
        sites, quats = self.site_positions(), self.object_quats()
        outcome = PickOutcome(
            feasible=True,
            success=False,
            picked=None,
            target=target,
            theta=theta,
            initial_sites=sites,
            initial_quats=quats,
        )
        if cfg.fix("unfeasible_targets") and pixel is not None and not self.reachable(pixel):
            # unfeasible whatever the IK finds: only the pick pose is solved (as the plan solves it), for the
            # gripper yaw and IK error the outcome reports; the place pose and the waypoints are skipped
            _, pick_pose = self._pick_poses(target, self.last_q.copy(), theta)
            outcome.gripper_yaw, outcome.ik_error = self._gripper_yaw(pick_pose, theta), pick_pose.position_error
            outcome.feasible = False
            return outcome
        plan, outcome.ik_error, outcome.gripper_yaw, ik_ok = self.plan(np.asarray(xy, dtype=float), theta)
        if cfg.fix("unfeasible_targets") and not ik_ok:
            outcome.feasible = False
            return outcome
        before = self.physics_steps
        final = self._run_controller(plan, theta, on_tick)
        goal = np.asarray(cfg.success_point)
        for i in range(self.n):
            if not self.picked[i] and norm(final[i] - goal) < cfg.success_radius:
                self.picked[i] = True
                outcome.success, outcome.picked = True, i
                break
        if cfg.fix("release_at_place"):
            self.data.ctrl[6:8] = cfg.controller.open_gripper
            self.last_q = plan[-1].copy()
            self.last_q[5] = theta
            self._park_picked()
        self.settle(cfg.post_pick_steps)
        outcome.steps = self.physics_steps - before
        return outcome

    def _park_picked(self) -> None:
        """Move placed objects to the output tray, at rest (they leave the scene as on a real feeder)."""
        rest_z, tilt = _rest_pose(self.n, self.config.data_dir)
        for k, (i, adr) in enumerate(zip(np.flatnonzero(self.picked), self.object_qadr[self.picked], strict=True)):
            spot = TRAY + np.array([0.06 * k, 0.0])
            self.data.qpos[adr : adr + 7] = [spot[0], spot[1], rest_z - PLANE_TOP, *tilt]
            dof = self.object_dofadr[i]
            self.data.qvel[dof : dof + 6] = 0.0
        mujoco.mj_forward(self.model, self.data)
