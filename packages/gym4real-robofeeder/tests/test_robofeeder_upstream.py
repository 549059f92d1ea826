"""Upstream fidelity: the reference's quaternion slip, crops and step semantics."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gym4real  # noqa: F401
from gym4real.robofeeder.reward import euler_xyz, reference_angle_error, reference_grasp_angle

quats = st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1)


@settings(max_examples=200, deadline=None)
@given(q=quats)
def test_euler_matches_scipy(q: list[float]) -> None:
    rotation = pytest.importorskip("scipy.spatial.transform").Rotation
    expected = rotation.from_quat(q).as_euler("xyz")
    got = euler_xyz(np.array(q))
    if abs(abs(expected[1]) - np.pi / 2) > 1e-3:  # away from gimbal lock
        np.testing.assert_allclose(np.cos(got - expected), 1.0, atol=1e-9)


def test_reference_angle_for_yaw_only_objects() -> None:
    # a yaw-only object (w, 0, 0, z) read as (x, y, z, w): e_x = pi - yaw, angle = wrap(2.35 + e_x)
    for yaw in np.linspace(-3, 3, 13):
        q = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
        phi = reference_grasp_angle(q)
        assert 0.0 <= phi <= np.pi
        assert np.isclose(np.cos(2 * (phi - (2.35 - yaw))), 1.0, atol=1e-9)  # equal modulo pi
    q = np.array([np.cos(2.15 / 2), 0.0, 0.0, np.sin(2.15 / 2)])  # phi = 0.2
    assert reference_angle_error(q, 1.0) == pytest.approx(0.8)
    assert reference_angle_error(q, np.pi) == pytest.approx(0.2)  # |0.2 - pi| > 2.6 is folded to pi - delta


def test_upstream_episode_runs_the_reference_script() -> None:
    env = gym.make("gym4real/robofeeder-picking-v0", fidelity="upstream", n_objects=3)
    env.reset(seed=0)
    sim = env.unwrapped.sim
    assert sim.physics_steps >= 900  # dropped from 0.21 m and settled 900 steps
    _, reward, _, _, info = env.step(np.zeros(3))
    assert info["feasible"] and -0.5 <= reward <= 0.5
    np.testing.assert_array_equal(sim.last_q, np.zeros(6))  # the reference never updates `last_pos`
    env.close()


def test_upstream_planning_samples_from_the_env_rng() -> None:
    env = gym.make("gym4real/robofeeder-planning-v0", fidelity="upstream")
    runs = []
    for _ in range(2):
        env.reset(seed=3)
        runs.append(env.step(1)[4]["agent_action"])
    env.close()
    np.testing.assert_array_equal(runs[0], runs[1])
