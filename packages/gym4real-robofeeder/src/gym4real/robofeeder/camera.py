"""Pinhole model of the fixed top-down camera: pixel <-> world maps on the picking plane.

As in the reference: P = I F R T built from the camera pose, F = diag(-f, f, 1) with
f = (W / 2) / tan(fovy / 2), principal point ((W - 1) / 2, (H - 1) / 2); a pixel maps back to the world
at the fixed homogeneous depth ``depth`` (0.42078046 m: camera height minus the top of a lying object).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gym4real.robofeeder.portable_math import dot, inv

#: Depth (m) at which the reference back-projects pixels.
REFERENCE_DEPTH = 0.42078046


@dataclass(frozen=True)
class CameraModel:
    """Projection of the top-down camera.

    Args:
        projection: The 3x4 matrix P (world homogeneous point -> homogeneous pixel).
        width: Image width (px).
        height: Image height (px).
        depth: Back-projection depth (m).
    """

    projection: np.ndarray
    width: int
    height: int
    depth: float = REFERENCE_DEPTH

    @classmethod
    def from_pose(
        cls,
        position: np.ndarray,
        rotation: np.ndarray,
        fovy_deg: float,
        width: int,
        height: int,
        depth: float = REFERENCE_DEPTH,
    ) -> CameraModel:
        """Build the model from the camera position, its world rotation matrix (columns = camera axes) and fovy."""
        f = (height / 2.0) / math.tan(math.radians(fovy_deg) / 2.0)
        intrinsics = np.array([[1.0, 0.0, (width - 1) / 2.0], [0.0, 1.0, (height - 1) / 2.0], [0.0, 0.0, 1.0]])
        focal = np.diag([-f, f, 1.0])
        world_to_cam = np.asarray(rotation, dtype=float).T
        translate = np.hstack([np.eye(3), -np.asarray(position, dtype=float).reshape(3, 1)])
        projection = dot(dot(dot(intrinsics, focal), world_to_cam), translate)
        return cls(projection=projection, width=width, height=height, depth=depth)

    @property
    def inverse(self) -> np.ndarray:
        """The reference's ``inv_cam``: the inverse of P with the row (0, 0, 0, 1) appended."""
        return inv(np.vstack([self.projection, [0.0, 0.0, 0.0, 1.0]]))

    def pixel_to_world(self, pixel: np.ndarray) -> np.ndarray:
        """World (x, y) of pixel(s) (u, v) on the picking plane; shape (..., 2) -> (..., 2)."""
        uv = np.asarray(pixel, dtype=float)
        d = self.depth
        homog = np.stack([-d * uv[..., 0], -d * uv[..., 1], np.full(uv.shape[:-1], -d), np.ones(uv.shape[:-1])], -1)
        return dot(homog, self.inverse.T)[..., :2]

    def world_to_pixel(self, point: np.ndarray) -> np.ndarray:
        """Pixel (u, v) of world point(s) (x, y, z); shape (..., 3) -> (..., 2)."""
        xyz = np.asarray(point, dtype=float)
        homog = dot(np.concatenate([xyz, np.ones((*xyz.shape[:-1], 1))], -1), self.projection.T)
        return homog[..., :2] / homog[..., 2:3]

    def plane_height(self) -> float:
        """World height (m) of the back-projection plane."""
        point = dot(np.array([-self.depth * 0.0, 0.0, -self.depth, 1.0]), self.inverse.T)
        return float(point[2])
