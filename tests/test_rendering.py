"""``render_mode="rgb_array"`` on every registered id (multi-objective variants included): Gymnasium's
checker, frames that follow the seed, dynamics that rendering leaves alone, and RecordVideo files."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.wrappers import RecordVideo

import gym4real
from gym4real.core.testing import assert_same_trace

#: The vector reward of the multi-objective variants is on purpose; Gymnasium's checker remarks on it.
pytestmark = pytest.mark.filterwarnings("ignore:.*reward returned by `step\\(\\)` must be a float:UserWarning")

#: Every id, the vector-reward variant of each multi-objective one included.
IDS = gym4real.list_envs()


def test_every_multi_objective_variant_is_covered() -> None:
    assert {"gym4real/dam-mo-v0", "gym4real/microgrid-mo-v0", "gym4real/wds-mo-v0"} <= set(IDS)
    assert all(i in gym.registry for i in IDS)


@pytest.mark.parametrize("env_id", IDS)
def test_env_checker_passes_with_rgb_array(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array")
    try:
        assert "rgb_array" in env.metadata["render_modes"]
        check_env(env.unwrapped)  # the render checks included
    finally:
        env.close()


def _episode(env_id: str, render_mode: str | None, steps: int = 6) -> tuple[list, list[np.ndarray]]:
    """A seeded rollout of random actions, its trace and (when rendering) the frame after each step."""
    env = gym.make(env_id, render_mode=render_mode, max_episode_steps=steps)
    trace, frames = [], []
    try:
        obs, _ = env.reset(seed=5)
        env.action_space.seed(5)
        trace.append(obs)
        if render_mode:
            frames.append(env.render())
        done = False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
            trace += [obs, reward, terminated, truncated]
            if render_mode:
                frames.append(env.render())
            done = terminated or truncated
    finally:
        env.close()
    return trace, frames


@pytest.mark.parametrize("env_id", IDS)
def test_frames_follow_the_seed_and_leave_the_dynamics_alone(env_id: str) -> None:
    plain, none = _episode(env_id, None)
    drawn, frames = _episode(env_id, "rgb_array")
    again, frames_again = _episode(env_id, "rgb_array")
    assert none == []
    assert_same_trace(plain, drawn)  # rendering does not change what the agent sees or earns
    assert_same_trace(drawn, again)
    assert len(frames) == len(frames_again) > 1
    for a, b in zip(frames, frames_again, strict=True):
        assert a.dtype == np.uint8 and a.ndim == 3 and a.shape[2] == 3
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("env_id", IDS)
def test_record_video_writes_the_episode(env_id: str, tmp_path: Path) -> None:
    from moviepy import VideoFileClip

    steps = 5
    env = RecordVideo(gym.make(env_id, render_mode="rgb_array", max_episode_steps=steps), str(tmp_path / "videos"))
    frames = []
    try:
        env.reset(seed=1)
        env.action_space.seed(1)
        frames.append(env.render())
        done = False
        while not done:
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            frames.append(env.render())
            done = terminated or truncated
    finally:
        env.close()
    (video,) = (tmp_path / "videos").glob("*.mp4")
    clip = VideoFileClip(str(video))
    try:
        decoded = list(clip.iter_frames())
        assert clip.size == [frames[0].shape[1], frames[0].shape[0]]
    finally:
        clip.close()
    assert len(decoded) == len(frames)
    for got, want in zip(decoded, frames, strict=True):  # H.264 is lossy: close, not equal
        assert np.abs(got.astype(float) - want).mean() < 12
