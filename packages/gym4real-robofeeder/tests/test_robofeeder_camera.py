"""Camera model: the reference's inverse projection, known pixel -> world values, round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gym4real.robofeeder.env import RoboFeederPickingImageEnv

# spec "Camera model and pixel <-> world mapping" (values of the reference with W = H = 300)
INV_CAM = np.array(
    [
        [0.00167428, 0.00175628, -0.51286938, -0.355],
        [0.00175628, -0.00167428, -0.01225855, 0.37],
        [0.0, 0.0, 1.0, 0.63],
        [0.0, 0.0, 0.0, 1.0],
    ]
)
KNOWN = [
    ((149.5, 149.5), (-0.355, 0.370)),
    ((0.0, 0.0), (-0.13919, 0.37516)),
    ((299.0, 299.0), (-0.57081, 0.36484)),
    ((30.0, 37.5), (-0.18804, 0.37941)),
    ((270.0, 37.5), (-0.35712, 0.20204)),
    ((30.0, 165.0), (-0.28227, 0.46923)),
    ((270.0, 165.0), (-0.45135, 0.29187)),
]


@pytest.fixture(scope="module")
def camera():
    env = RoboFeederPickingImageEnv()
    yield env.sim.camera
    env.close()


def test_inverse_matches_the_reference(camera) -> None:
    np.testing.assert_allclose(camera.inverse, INV_CAM, atol=2e-8)


@pytest.mark.parametrize(("pixel", "world"), KNOWN)
def test_known_pixels(camera, pixel, world) -> None:
    np.testing.assert_allclose(camera.pixel_to_world(np.array(pixel)), world, atol=1e-5)


@settings(max_examples=200, deadline=None)
@given(u=st.floats(0, 299), v=st.floats(0, 299))
def test_pixel_world_pixel_within_1mm(camera, u: float, v: float) -> None:
    xy = camera.pixel_to_world(np.array([u, v]))
    back = camera.world_to_pixel(np.array([xy[0], xy[1], camera.plane_height()]))
    assert np.linalg.norm(back - [u, v]) * 1.05e-3 < 1e-3  # one pixel is about 1.02 mm on the plane
    again = camera.pixel_to_world(back)
    assert np.linalg.norm(again - xy) < 1e-3


@settings(max_examples=100, deadline=None)
@given(x=st.floats(-0.5, -0.2), y=st.floats(0.22, 0.52))
def test_world_pixel_world_within_1mm(camera, x: float, y: float) -> None:
    pixel = camera.world_to_pixel(np.array([x, y, camera.plane_height()]))
    assert np.linalg.norm(camera.pixel_to_world(pixel) - [x, y]) < 1e-3


def test_plane_height_is_object_top(camera) -> None:
    # 0.63 m camera height minus the reference depth 0.42078046 m
    assert camera.plane_height() == pytest.approx(0.63 - 0.42078046, abs=1e-6)
