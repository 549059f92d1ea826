"""Inverse kinematics of the TX2-60 on the MJCF itself (MuJoCo Jacobians, damped least squares).

Replaces the reference's ikpy chain built from the URDF (same kinematics: the MJCF joint offsets
along their own axes do not move the frames). The tool must point straight down; the yaw about the
vertical is either left free (the reference's orientation mode "Z", joints 1-6 solved) or fixed by
holding joint 6 at the commanded grasp angle (joints 1-5 solved).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gym4real.robofeeder._gl import mujoco

ARM_JOINTS = tuple(f"joint_{i}" for i in range(1, 7))
DOWN = np.array([0.0, 0.0, -1.0])


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
    """

    def __init__(self, model: mujoco.MjModel, tool_offset: np.ndarray) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.tool_offset = np.asarray(tool_offset, dtype=float)
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
        return self.data.xpos[self.body] + rot @ self.tool_offset, rot.copy()

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
            axis = rot[:, 2]
            e_pos = target - point
            e_rot = np.cross(axis, DOWN)[:2]
            if axis @ DOWN < 0.0:  # pointing up: the cross product vanishes, push towards any horizontal tilt
                e_rot = e_rot + np.array([1.0, 0.0])
            err_p, err_r = float(np.linalg.norm(e_pos)), float(np.linalg.norm(np.cross(axis, DOWN)))
            if err_p < tol and err_r < 10 * tol and axis @ DOWN > 0:
                break
            mujoco.mj_comPos(self.model, self.data)
            mujoco.mj_jac(self.model, self.data, self._jacp, self._jacr, point, self.body)
            jac = np.vstack([self._jacp[:, dofs], self._jacr[:2, dofs]])
            err = np.concatenate([e_pos, e_rot])
            step = jac.T @ np.linalg.solve(jac @ jac.T + damping * np.eye(5), err)
            q[active] = np.clip(q[active] + step, self.lower[active], self.upper[active])
        ok = err_p < 10 * tol and err_r < 100 * tol
        return IKResult(q=q, position_error=err_p, axis_error=err_r, ok=bool(ok))

    def solve_from(self, target: np.ndarray, seeds: list[np.ndarray], *, fixed_j6: float | None = None) -> IKResult:
        """:meth:`solve` from each seed in turn; the first converged solution, else the most accurate one."""
        best: IKResult | None = None
        for seed in seeds:
            result = self.solve(target, seed, fixed_j6=fixed_j6)
            if result.ok:
                return result
            if best is None or result.position_error < best.position_error:
                best = result
        assert best is not None
        return best
