"""Inverse kinematics of the TX2-60 on the MJCF itself (MuJoCo forward kinematics and Jacobians).

The reference plans with an ikpy chain built from the URDF (same kinematics: the MJCF joint offsets
along their own axes do not move the frames). Two solvers, one per tool convention:

* :meth:`ArmKinematics.solve_free_yaw`, the reference's problem as ikpy poses it: the chain's end frame
  (the left finger's, tilted 1 degree about the flange x axis in the URDF) at the target with its z axis
  pointing down, yaw free, all six joints solved by SciPy's bounded least squares from the given seed
  within the URDF's joint limits, best effort returned. From the reference's zero seed it lands on the
  reference's wrist branch (joint 4 near 0).
* :meth:`ArmKinematics.solve`, damped least squares with joint 6 held at the grasp angle (corrected mode,
  the point between the fingers) or free.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gym4real.robofeeder._gl import mujoco
from gym4real.robofeeder.portable_math import dot, norm, solve

ARM_JOINTS = tuple(f"joint_{i}" for i in range(1, 7))
DOWN = np.array([0.0, 0.0, -1.0])
FLANGE_AXIS = np.array([0.0, 0.0, 1.0])
#: Joint limits (rad) of ``tx2_60.urdf``, which the reference's ikpy chain optimises within (the MJCF's
#: ranges are these rounded to 5 decimals).
URDF_LOWER = np.array(
    [0.0, -2.2252947962927703, -2.6616271092913526, -4.71238898038469, -2.111848394913139, -4.71238898038469]
)
URDF_UPPER = np.array(
    [6.283185307179586, 2.2252947962927703, 2.6616271092913526, 4.71238898038469, 2.3125612588924866, 4.71238898038469]
)
#: The end frame of the reference's chain (``tx2_60.urdf``, joint ``tool0_leftfinger``): the left finger's
#: origin in the flange frame (m), and its z axis, tilted by the joint's roll of 0.0174533 rad.
LEFT_FINGER_TOOL = np.array([0.0, -0.0073, 0.075])
LEFT_FINGER_AXIS = np.array([0.0, -math.sin(0.0174533), math.cos(0.0174533)])


@dataclass(frozen=True)
class IKResult:
    """A solution: joint angles 1-6, position error (m), tool-axis error (rad), and whether both are in tolerance."""

    q: np.ndarray
    position_error: float
    axis_error: float
    ok: bool


class ArmKinematics:
    """Forward and inverse kinematics of a point fixed to the flange, on a private ``MjData``.

    Args:
        model: The compiled scene (only read).
        tool_offset: The controlled point in the flange frame (m).
        tool_axis: The tool axis (unit vector) in the flange frame, to point down.
    """

    def __init__(self, model: mujoco.MjModel, tool_offset: np.ndarray, tool_axis: np.ndarray = FLANGE_AXIS) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.tool_offset = np.asarray(tool_offset, dtype=float)
        self.tool_axis = np.asarray(tool_axis, dtype=float)
        self.body = model.body("flange").id
        joints = [model.joint(name) for name in ARM_JOINTS]
        self.qadr = np.array([j.qposadr[0] for j in joints])
        self.dofadr = np.array([j.dofadr[0] for j in joints])
        self.lower = np.array([j.range[0] for j in joints])
        self.upper = np.array([j.range[1] for j in joints])
        self._jacp = np.zeros((3, model.nv))
        self._jacr = np.zeros((3, model.nv))

    def forward(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tool point (world) and flange rotation matrix for joint angles ``q`` (6)."""
        self.data.qpos[self.qadr] = q
        mujoco.mj_kinematics(self.model, self.data)
        rot = self.data.xmat[self.body].reshape(3, 3)
        return self.data.xpos[self.body] + dot(rot, self.tool_offset), rot.copy()

    def solve(
        self,
        target: np.ndarray,
        seed: np.ndarray,
        *,
        fixed_j6: float | None = None,
        iterations: int = 200,
        tol: float = 1e-4,
        damping: float = 1e-3,
    ) -> IKResult:
        """Joint angles placing the tool point at ``target`` (world) with the tool axis pointing down.

        Args:
            target: World position (m).
            seed: Initial joint angles (6).
            fixed_j6: Hold joint 6 at this angle (the grasp yaw) and solve joints 1-5; None solves all six.
            iterations: Maximum Gauss-Newton iterations.
            tol: Position tolerance (m); the axis tolerance is ``10 * tol`` rad.
            damping: Levenberg-Marquardt damping of the least-squares step.
        """
        q = np.clip(np.asarray(seed, dtype=float).copy(), self.lower, self.upper)
        active = np.arange(5) if fixed_j6 is not None else np.arange(6)
        if fixed_j6 is not None:
            q[5] = fixed_j6
        dofs = self.dofadr[active]
        target = np.asarray(target, dtype=float)
        err_p = err_r = np.inf
        for _ in range(iterations):
            point, rot = self.forward(q)
            axis = dot(rot, self.tool_axis)
            e_pos = target - point
            e_rot = np.cross(axis, DOWN)[:2]
            if dot(axis, DOWN) < 0.0:  # pointing up: the cross product vanishes, push towards any horizontal tilt
                e_rot = e_rot + np.array([1.0, 0.0])
            err_p, err_r = float(norm(e_pos)), float(norm(np.cross(axis, DOWN)))
            if err_p < tol and err_r < 10 * tol and dot(axis, DOWN) > 0:
                break
            mujoco.mj_comPos(self.model, self.data)
            mujoco.mj_jac(self.model, self.data, self._jacp, self._jacr, point, self.body)
            jac = np.vstack([self._jacp[:, dofs], self._jacr[:2, dofs]])
            err = np.concatenate([e_pos, e_rot])
            step = dot(jac.T, solve(dot(jac, jac.T) + damping * np.eye(5), err))
            q[active] = np.clip(q[active] + step, self.lower[active], self.upper[active])
        ok = err_p < 10 * tol and err_r < 100 * tol
        return IKResult(q=q, position_error=err_p, axis_error=err_r, ok=bool(ok))

    def solve_from(self, target: np.ndarray, seeds: list[np.ndarray], *, fixed_j6: float | None = None) -> IKResult:
        """:meth:`solve` from each seed in turn; the first converged solution, else the most accurate one.

        A seed equal to an earlier one is skipped (the solve is deterministic: it would fail again).
        """
        best: IKResult | None = None
        for i, seed in enumerate(seeds):
            if any(np.array_equal(seed, earlier) for earlier in seeds[:i]):
                continue
            result = self.solve(target, seed, fixed_j6=fixed_j6)
            if result.ok:
                return result
            if best is None or result.position_error < best.position_error:
                best = result
        assert best is not None
        return best

    def solve_free_yaw(self, target: np.ndarray, seed: np.ndarray, tol: float = 1e-4) -> IKResult:
        """The reference planner's inverse kinematics: tool point at ``target`` (world), tool axis down, yaw free.

        The problem ikpy solves for the reference: residuals (tool point - target, tool axis - down) over
        joints 1-6, SciPy's trust-region reflective least squares from ``seed`` within the URDF's joint
        limits, finite-difference Jacobian. Its best effort is returned, converged or not (``ok`` says which,
        with the tolerances of :meth:`solve`).
        """
        from scipy.optimize import least_squares  # the upstream mode only: SciPy costs ~0.8 s to import

        target = np.asarray(target, dtype=float)

        def residuals(q: np.ndarray) -> np.ndarray:
            point, rot = self.forward(q)
            return np.concatenate([point - target, dot(rot, self.tool_axis) - DOWN])

        seed = np.clip(np.asarray(seed, dtype=float), URDF_LOWER, URDF_UPPER)
        q = least_squares(residuals, seed, bounds=(URDF_LOWER, URDF_UPPER)).x
        point, rot = self.forward(q)
        err_p = float(norm(point - target))
        err_r = float(norm(np.cross(dot(rot, self.tool_axis), DOWN)))
        return IKResult(q=q, position_error=err_p, axis_error=err_r, ok=bool(err_p < 10 * tol and err_r < 100 * tol))
