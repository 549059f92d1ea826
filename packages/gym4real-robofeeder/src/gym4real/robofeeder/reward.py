"""Reward shaping of a failed pick and the grasp-angle conventions (reference and corrected).

The reference computes the object's grasp angle from the MuJoCo quaternion (w, x, y, z) handed to
``scipy.Rotation.from_quat``, which reads (x, y, z, w): a convention slip around which the offset 2.35
was tuned (defect 6). :func:`reference_grasp_angle` reproduces it without SciPy. The corrected mode
compares the true object yaw with the planned gripper yaw, modulo pi.
"""

from __future__ import annotations

import math

import numpy as np

from gym4real.robofeeder.config import RewardSection
from gym4real.robofeeder.portable_math import norm

REFERENCE_OFFSET = 2.35
#: Above this error the reference folds the angle error: delta = pi - delta.
REFERENCE_FOLD = 2.6


def euler_xyz(quat_xyzw: np.ndarray) -> np.ndarray:
    """Extrinsic 'xyz' Euler angles of a scalar-last quaternion (SciPy's ``as_euler("xyz")``)."""
    x, y, z, w = np.asarray(quat_xyzw, dtype=float) / norm(quat_xyzw)
    r20 = 2.0 * (x * z - w * y)
    r21 = 2.0 * (y * z + w * x)
    r22 = 1.0 - 2.0 * (x * x + y * y)
    r10 = 2.0 * (x * y + w * z)
    r00 = 1.0 - 2.0 * (y * y + z * z)
    return np.array([math.atan2(r21, r22), -math.asin(min(max(r20, -1.0), 1.0)), math.atan2(r10, r00)])


def _wrap_once(angle: float) -> float:
    """Add or subtract pi once to bring ``angle`` towards [0, pi] (the reference's ``wrap``)."""
    if angle > np.pi:
        return angle - np.pi
    if angle < 0.0:
        return angle + np.pi
    return angle


def reference_grasp_angle(quat_wxyz: np.ndarray) -> float:
    """The reference's object angle: wrap(2.35 + e_x), e_x from the (w, x, y, z) quaternion read as (x, y, z, w)."""
    return _wrap_once(REFERENCE_OFFSET + float(euler_xyz(np.asarray(quat_wxyz, dtype=float))[0]))


def reference_angle_error(quat_wxyz: np.ndarray, theta: float) -> float:
    """|phi - theta|, folded to pi - delta above 2.6 rad (the reference's "grasp yaw modulo pi")."""
    delta = abs(reference_grasp_angle(quat_wxyz) - theta)
    return float(np.pi - delta) if delta > REFERENCE_FOLD else float(delta)


def reference_orientation_ok(quat_wxyz: np.ndarray) -> bool:
    """The reference planning check: third 'xyz' Euler angle of the slipped quaternion in (0, 0.7)."""
    e_z = float(euler_xyz(np.asarray(quat_wxyz, dtype=float))[2])
    return 0.0 < e_z < 0.7


def angle_error_mod_pi(gripper_yaw: float, object_yaw: float) -> float:
    """Smallest angle (rad, in [0, pi/2]) between the gripper and object axes, modulo pi."""
    delta = (gripper_yaw - object_yaw) % np.pi
    return float(min(delta, np.pi - delta))


def shaped(distance: float, angle_error: float, reward: RewardSection) -> tuple[float, float, float]:
    """Failed-pick reward before the 1/T scaling: (-1, distance term, rotation term); their sum is the reward.

    ``-1 + lambda exp(-alpha_d d^2) + (1 - lambda) exp(-alpha_theta dtheta^2)`` with
    ``alpha = ln 2 / delta^2`` (each term is one half at its threshold).
    """
    alpha_d = math.log(2.0) / reward.delta_d**2
    alpha_t = math.log(2.0) / reward.delta_theta**2
    lam = reward.distance_weight
    return (-1.0, lam * math.exp(-alpha_d * distance**2), (1.0 - lam) * math.exp(-alpha_t * angle_error**2))
