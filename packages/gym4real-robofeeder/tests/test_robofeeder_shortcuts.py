"""The picking speed shortcuts change nothing an agent sees: results equal the full path's."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import fields

import numpy as np

from gym4real.robofeeder.env import RoboFeederPickingImageEnv


def test_a_target_outside_the_window_reports_the_full_plans_pick_pose_without_planning_the_rest() -> None:
    """Random targets outside the reachable window: the outcome's gripper yaw and IK error are the full plan's
    (bit for bit), the pick is unfeasible, and the cell does not move."""
    env = RoboFeederPickingImageEnv()
    env.reset(seed=3)
    sim = env.sim
    rng = np.random.default_rng(7)
    state = sim.data.qpos.copy()
    checked = unplanned = 0
    while checked < 8:
        pixel = rng.uniform(0.0, env.size, 2)
        if sim.reachable(pixel):
            continue
        xy, theta = sim.camera.pixel_to_world(pixel), float(rng.uniform(0.0, np.pi))
        _, ik_error, yaw, ik_ok = sim.plan(xy, theta)
        outcome = sim.pick(xy, theta, pixel)
        assert not outcome.feasible and not outcome.success and outcome.steps == 0
        assert (outcome.gripper_yaw, outcome.ik_error) == (yaw, ik_error)
        np.testing.assert_array_equal(sim.data.qpos, state)
        if not ik_ok:  # beyond the arm's reach too: the whole plan's outcome, with no window check, is the same
            whole = sim.pick(xy, theta)
            for f in fields(outcome):
                a, b = getattr(whole, f.name), getattr(outcome, f.name)
                assert a is b is None or np.array_equal(a, b), f.name
            unplanned += 1
        checked += 1
    assert unplanned >= 2
    env.close()


def test_the_corrected_mode_does_not_import_scipy() -> None:
    """SciPy (about 0.8 s to import) serves the upstream mode's planner only."""
    code = (
        "import sys, gymnasium as gym, gym4real\n"
        "env = gym.make('gym4real/robofeeder-picking-v1')\n"
        "env.reset(seed=0)\n"
        "env.step(env.action_space.sample())\n"
        "print('scipy' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300)
    assert out.stdout.split()[-1] == "False"
