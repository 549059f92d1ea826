"""Forked workers of a parent that has rendered: they render, or they fail at once; they never hang.

Each scenario runs in a subprocess with a hard timeout, so that a regression (a child waiting for good
on the OpenGL state it inherited) fails the test instead of hanging the suite.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap

import pytest

import gym4real

ROBOFEEDER = [e for e in gym4real.list_envs() if e.startswith("gym4real/robofeeder-")]
pytestmark = pytest.mark.skipif(sys.platform != "linux" or not ROBOFEEDER, reason="fork and robofeeder on Linux")

#: Seconds a scenario may take: it needs about 5 (a few env constructions); a hang is cut off here.
TIMEOUT = 120


def run_scenario(code: str) -> tuple[int, str, str]:
    """Run ``code`` in a fresh interpreter (its own process group); a run past TIMEOUT is a failure.

    On a timeout the whole group is killed: the forked workers that hung go with their parent.
    """
    proc = subprocess.Popen(
        [sys.executable, "-W", "ignore", "-c", textwrap.dedent(code)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        out, err = proc.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"the scenario hung (killed after {TIMEOUT} s); output so far: {out[-2000:]} {err[-2000:]}")
    return proc.returncode, out, err


@pytest.mark.parametrize("env_id", ROBOFEEDER)
def test_fork_after_rendering_in_parent_renders_in_children(env_id: str) -> None:
    code, out, err = run_scenario(
        f"""
        import gymnasium as gym, numpy as np
        import gym4real

        def leaves(obs):
            return [obs[k] for k in sorted(obs)] if isinstance(obs, dict) else [obs]

        env = gym.make({env_id!r})
        first, _ = env.reset(seed=3)  # the parent renders: its EGL display is open
        venv = gym.vector.AsyncVectorEnv([lambda: gym.make({env_id!r})] * 2, context="fork")
        obs, _ = venv.reset(seed=[3, 4])
        for mine, theirs in zip(leaves(first), leaves(obs)):
            np.testing.assert_array_equal(theirs[0], mine)  # a child renders what the parent rendered
        venv.step(venv.action_space.sample())
        venv.close()
        again, _ = env.reset(seed=3)  # the parent renders again after the fork
        for a, b in zip(leaves(first), leaves(again)):
            np.testing.assert_array_equal(a, b)
        env.close()
        print("OK")
        """
    )
    assert code == 0 and "OK" in out, err[-3000:]


def test_fork_with_a_foreign_renderer_open_fails_at_once_with_the_fix() -> None:
    code, out, err = run_scenario(
        f"""
        import gymnasium as gym
        import gym4real
        from gym4real.robofeeder._gl import mujoco

        # a MuJoCo renderer that is not gym4real's holds the EGL display across the fork
        model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='.1'/></worldbody></mujoco>")
        data = mujoco.MjData(model)
        mine = mujoco.Renderer(model, 32, 32)
        mine.update_scene(data)
        before = mine.render().copy()
        venv = gym.vector.AsyncVectorEnv([lambda: gym.make({ROBOFEEDER[0]!r})], context="fork")
        try:
            venv.reset(seed=0)
        except Exception as exc:
            print("ERROR", exc)
        venv.close()
        mine.update_scene(data)
        assert (mine.render() == before).all()  # the foreign renderer was left working
        print("DONE")
        """
    )
    assert code == 0 and "DONE" in out, err[-3000:]
    assert "forked" in out and "context='spawn'" in out, out[-3000:]
