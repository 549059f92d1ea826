"""``render_mode="rgb_array_list"``: a step is one whole pick, filmed tick by tick (the docs GIF shows it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gym4real.bench.record import GifFrames, record
from gym4real.robofeeder.env import RoboFeederPickingEnv


def _oracle_pick(render_mode: str | None) -> tuple[RoboFeederPickingEnv, list, tuple]:
    env = RoboFeederPickingEnv(render_mode=render_mode)
    obs, _ = env.reset(seed=0)
    start = env.render()
    obs, reward, terminated, truncated, info = env.step(env.oracle_action())
    return env, [start, env.render()], (obs, reward, terminated, truncated, info)


def test_a_filmed_step_shows_the_arm_at_each_tick_and_ends_on_the_steps_frame() -> None:
    plain, _, expected = _oracle_pick(None)
    single, (first, last), _ = _oracle_pick("rgb_array")
    filmed, (start, pick), outcome = _oracle_pick("rgb_array_list")
    for env in (plain, single, filmed):
        env.close()
    np.testing.assert_array_equal(outcome[0], expected[0])  # filming leaves what the agent sees and earns alone
    assert outcome[1:4] == expected[1:4] and outcome[4]["success"] and expected[4]["success"]
    assert len(start) == 1
    np.testing.assert_array_equal(start[0], first)
    np.testing.assert_array_equal(pick[-1], last)
    ticks = pick[:-1]
    assert len(ticks) >= 20  # the plan's 20 waypoints, each one tick, plus the gripper's and the final ticks
    moved = [not np.array_equal(frame, first) and not np.array_equal(frame, last) for frame in ticks]
    assert sum(moved) >= len(ticks) // 2  # the arm is in view for most of the pick
    assert len(filmed.render()) == 0  # each frame is handed out once


def test_record_films_the_whole_pick(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    env, (start, pick), _ = _oracle_pick("rgb_array_list")
    env.close()
    offered: list[np.ndarray] = []
    keep = GifFrames.add
    monkeypatch.setattr(GifFrames, "add", lambda self, frame: (offered.append(frame), keep(self, frame))[1])
    (gif,) = record("gym4real/robofeeder-picking-v0", "oracle", out=tmp_path, mp4=False, gif_frames=200)
    assert gif.is_file()
    assert len(offered) == len(start) + len(pick) > 20  # the start, each tick of the pick, the end
    caption = offered[0].shape[0] - start[0].shape[0]
    for shown, frame in zip(offered, [*start, *pick], strict=True):
        np.testing.assert_array_equal(shown[caption:], frame)


def test_an_idle_planning_step_is_filmed_as_its_one_unchanged_frame() -> None:
    from gym4real.robofeeder.planning import RoboFeederPlanningEnv

    filmed = RoboFeederPlanningEnv(render_mode="rgb_array_list")
    single = RoboFeederPlanningEnv(render_mode="rgb_array")
    try:
        for env in (filmed, single):
            env.reset(seed=4)
            env.render()
            env.step(0)  # idle: ends the episode, moves nothing
        (frame,) = filmed.render()  # the step's frame, so that a recording ends on the last step's caption
        np.testing.assert_array_equal(frame, single.render())
    finally:
        filmed.close()
        single.close()
