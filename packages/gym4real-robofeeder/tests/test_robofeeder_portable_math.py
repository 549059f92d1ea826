"""portable_math: numpy's products, solves and norms (to rounding), summed in the documented order."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gym4real.robofeeder.portable_math import arccos, atan2, dot, exp, inv, norm, solve

SHAPES = [((3, 3), (3,)), ((5, 6), (6, 5)), ((6,), (6, 4)), ((7, 2, 4), (4, 4))]


@pytest.mark.parametrize(("shape_a", "shape_b"), SHAPES)
def test_dot_is_numpys_product(shape_a: tuple[int, ...], shape_b: tuple[int, ...]) -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=shape_a), rng.normal(size=shape_b)
    np.testing.assert_allclose(dot(a, b), a @ b, rtol=1e-13, atol=1e-14)
    assert dot(a, b).shape == (a @ b).shape


def test_dot_adds_left_to_right_and_keeps_float32() -> None:
    # 1e16 + 1 rounds to 1e16: left to right, the order of the terms decides whether the 1 survives
    assert dot(np.array([1e16, 1.0, -1e16]), np.ones(3)) == 0.0
    assert dot(np.array([1e16, -1e16, 1.0]), np.ones(3)) == 1.0
    rgb = np.arange(12, dtype=np.float32).reshape(2, 2, 3)
    weights = np.array([0.2989, 0.5870, 0.1140], np.float32)
    gray = dot(rgb, weights)
    assert gray.dtype == np.float32
    r, g, b = (rgb[..., k] * weights[k] for k in range(3))
    np.testing.assert_array_equal(gray, (r + g) + b)


def test_dot_refuses_shapes_that_do_not_chain() -> None:
    with pytest.raises(ValueError, match=r"\(3, 2\) and \(3,\)"):
        dot(np.ones((3, 2)), np.ones(3))


def test_solve_and_inverse_are_numpys() -> None:
    rng = np.random.default_rng(1)
    a = rng.normal(size=(5, 5)) + 0.01 * np.eye(5)
    b, bs = rng.normal(size=5), rng.normal(size=(5, 3))
    np.testing.assert_allclose(solve(a, b), np.linalg.solve(a, b), rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(solve(a, bs), np.linalg.solve(a, bs), rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(dot(a, inv(a)), np.eye(5), atol=1e-12)
    # partial pivoting: a zero on the diagonal is no obstacle
    np.testing.assert_array_equal(solve(np.array([[0.0, 2.0], [4.0, 0.0]]), np.array([2.0, 8.0])), [2.0, 1.0])


def test_solve_refuses_singular_and_mismatched_systems() -> None:
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        solve(np.array([[1.0, 2.0], [2.0, 4.0]]) * 0.0, np.ones(2))
    with pytest.raises(ValueError, match=r"square matrix"):
        solve(np.ones((2, 3)), np.ones(2))


def test_norm_and_elementary_functions() -> None:
    assert float(norm([3.0, 4.0])) == 5.0
    v = np.random.default_rng(2).normal(size=(4, 3))
    np.testing.assert_allclose(norm(v), np.linalg.norm(v, axis=-1), rtol=1e-15)
    y, x = np.array([1.0, -1.0, 0.5]), np.array([2.0, -3.0, 0.0])
    assert atan2(y, x).tolist() == [math.atan2(a, b) for a, b in zip(y, x, strict=True)]
    assert float(atan2(1.0, 1.0)) == math.atan2(1.0, 1.0)
    assert arccos(np.array([0.5, -1.0])).tolist() == [math.acos(0.5), math.acos(-1.0)]
    assert exp(np.array([0.0, 1.0])).tolist() == [1.0, math.e]
