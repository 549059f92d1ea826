"""``gym4real record``: an MP4 and a GIF per episode of a policy, captioned with its step and objective so far."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from PIL import Image, ImageSequence

import gym4real
from gym4real.bench.policies import make_policy
from gym4real.bench.record import CAPTION_CHARS, GifFrames, record, recording_mode
from gym4real.cli import main
from gym4real.core.canvas import CHAR_HEIGHT, captioned
from gym4real.core.errors import Gym4RealError
from gym4real.core.registry import base_env, baseline_names, non_causal, registry

IDS = gym4real.list_envs()


def _rule_based(env_id: str) -> str:
    upper = non_causal(env_id)  # an upper reference plans with hindsight: not a rule
    rules = [b for b in baseline_names(env_id) if b not in ("random", "pretrained", *upper)]
    return rules[0] if rules else "random"  # planning-v0: its only causal baseline is random


def _frames(path: Path) -> list[np.ndarray]:
    with Image.open(path) as gif:
        return [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(gif)]


def _expected_last_frame(
    env_id: str, policy: str, seed: int, max_steps: int, label: str | None = None
) -> tuple[int, np.ndarray]:
    """The last frame of the episode, captioned (with ``label``, default ``policy``) from a run of our own.

    The caption's score is the protocol's objective: the sum of its reward components (the reward where the
    protocol names none; a vector-reward variant's scalar).
    """
    spec = registry().benchmarks.get(base_env(env_id))
    objective = spec.objective if spec is not None else ()
    env = gym.make(env_id, render_mode="rgb_array", max_episode_steps=max_steps)
    try:
        act = make_policy(env_id, policy, env)
        reset = getattr(act, "reset", None)
        if reset is not None:
            reset(seed)
        obs, _ = env.reset(seed=seed)
        total, steps, done = 0.0, 0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(act(obs))
            if objective:
                total += sum(float(info["reward_components"][c]) for c in objective)
            else:
                total += float(info.get("scalar_reward", reward))  # a vector-reward variant's caption is its scalar
            steps += 1
            done = terminated or truncated
        progress = f"seed {seed}  step {steps}  objective {total:.6g}".ljust(CAPTION_CHARS)
        lines = (f"{env_id}  policy {label or policy}", progress)
        return steps, captioned(env.render(), lines)
    finally:
        env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_record_writes_a_captioned_mp4_and_gif_per_episode(env_id: str, tmp_path: Path) -> None:
    pytest.importorskip("moviepy", reason="the MP4 needs the `video` extra")
    import imageio.v2 as imageio  # a dependency of moviepy; its ffmpeg reader yields every frame of the file
    # (moviepy's iter_frames stops at duration x fps rounded down: 85 of an 86-frame MP4 at 15 fps, 5.73 s)

    policy = _rule_based(env_id)
    args = ["record", env_id, "--policy", policy, "--episodes", "2", "--seed", "3", "--out", str(tmp_path)]
    assert main([*args, "--max-steps", "4", "--quiet"]) == 0
    name = env_id.split("/")[1]
    for seed in (3, 4):
        steps, want = _expected_last_frame(env_id, policy, seed, 4)
        gif = _frames(tmp_path / f"{name}-{policy}-seed{seed}.gif")
        with imageio.get_reader(tmp_path / f"{name}-{policy}-seed{seed}.mp4", "ffmpeg") as reader:
            video = [frame for frame in reader]  # not list(reader): it asks the length, infinite here
        if recording_mode(env_id) == "rgb_array":
            assert len(gif) == len(video) == steps + 1  # the reset, then every step
        else:  # a robot's every frame within its steps; the GIF keeps at most 100 of them (Pillow also merges
            # identical consecutive frames, such as the arm standing still)
            assert len(video) > steps + 1 and steps + 1 <= len(gif) <= min(len(video), 100)
        assert gif[-1].shape == video[-1].shape == want.shape
        band = 6 + 2 * (CHAR_HEIGHT + 2)  # the caption: env, policy, seed, step and objective
        assert np.abs(gif[-1][:band].astype(int) - want[:band]).max() <= 8
        assert np.abs(video[-1].astype(float) - want).mean() < 12


def test_record_plays_a_trained_model_given_as_kind_path(tmp_path: Path) -> None:
    from gym4real.rl.tabular import StateIndexer, save_qtable

    env_id = "gym4real/elevator-v0"
    indexer = StateIndexer(gym.make(env_id).observation_space)
    q = np.zeros((indexer.n_states, 3))
    q[:, 2] = 1.0  # a table whose greedy action is always "up"
    save_qtable(tmp_path / "q.npz", q, env_id, "qlearning", indexer.radices)
    policy = f"qlearning:{tmp_path / 'q.npz'}"
    args = ["record", env_id, "--policy", policy, "--out", str(tmp_path), "--max-steps", "12", "--no-mp4", "--quiet"]
    assert main(args) == 0
    assert not list(tmp_path.glob("*.mp4"))
    gif = _frames(tmp_path / "elevator-v0-qlearning-q-seed0.gif")
    steps, want = _expected_last_frame(env_id, policy, 0, 12, label="qlearning-q")
    assert len(gif) == steps + 1 == 13
    np.testing.assert_array_equal(gif[-1], want)  # the cabin went up: the model's episode, captioned


def _without_moviepy(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("moviepy", "moviepy.video.io.ffmpeg_writer"):
        monkeypatch.setitem(sys.modules, name, None)  # `import` raises ImportError, as where it is not installed


def test_record_without_moviepy_writes_the_gif_and_says_the_mp4_needs_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _without_moviepy(monkeypatch)
    env_id = "gym4real/elevator-v0"
    args = ["record", env_id, "--policy", "longest_first", "--out", str(tmp_path), "--max-steps", "5", "--quiet"]
    assert main(args) == 0
    out, err = capsys.readouterr()
    assert not list(tmp_path.glob("*.mp4"))
    gif = tmp_path / "elevator-v0-longest_first-seed0.gif"
    assert out.splitlines() == [f"wrote {gif}"]
    assert err.splitlines() == [
        'gym4real: warning: writing an MP4 needs MoviePy: `pip install "gym4real-core[video]"`; writing the GIF only'
    ]
    steps, want = _expected_last_frame(env_id, "longest_first", 0, 5)
    frames = _frames(gif)
    assert len(frames) == steps + 1
    np.testing.assert_array_equal(frames[-1], want)


def test_record_of_the_mp4_alone_without_moviepy_names_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _without_moviepy(monkeypatch)
    with pytest.raises(Gym4RealError, match=re.escape('pip install "gym4real-core[video]"')):
        record("gym4real/elevator-v0", "longest_first", out=tmp_path, max_steps=2, gif=False)
    assert not list(tmp_path.iterdir())


def test_gif_keeps_evenly_spaced_frames_and_the_last(tmp_path: Path) -> None:
    keeper = GifFrames(limit=10)
    for i in range(1000):
        keeper.add(np.full((2, 2, 3), (i // 256, i % 256, 0), dtype=np.uint8))
    keeper.save(tmp_path / "a.gif", fps=10)
    index = [int(f[0, 0, 0]) * 256 + int(f[0, 0, 1]) for f in _frames(tmp_path / "a.gif")]
    assert len(index) <= 10
    assert index[-1] == 999
    spacing = np.diff(index[:-1])
    assert index[0] == 0 and len(set(spacing)) == 1 and 999 - index[-2] <= spacing[0]


@pytest.mark.parametrize(("shape", "factor"), [((21, 47), 8), ((121, 47), 3), ((300, 300), 1), ((320, 480), 1)])
def test_small_frames_are_enlarged_whole_under_the_caption(shape: tuple[int, int], factor: int) -> None:
    # 8 = the smallest whole factor to 360 px wide; 3 = the largest that stays within 480 px high
    h, w = shape
    frame = np.random.default_rng(0).integers(0, 256, size=(h, w, 3), dtype=np.uint8)
    out = captioned(frame, ["one line", "two"])
    assert out.shape[0] % 2 == 0 and out.shape[1] % 2 == 0 and out.dtype == np.uint8
    band = 6 + 2 * (CHAR_HEIGHT + 2)
    x = (out.shape[1] - w * factor) // 2
    assert out.shape[0] - (band + h * factor) in (0, 1)
    np.testing.assert_array_equal(out[band : band + h * factor, x : x + w * factor][::factor, ::factor], frame)
    if factor > 1:
        np.testing.assert_array_equal(out[band + factor - 1, x + factor - 1], frame[0, 0])


def test_record_errors_are_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["record", "gym4real/elevator-v0", "--policy", "longest", "--out", str(tmp_path), "--quiet"]) == 2
    assert "unknown policy `longest`" in capsys.readouterr().err
    args = ["record", "gym4real/elevator-v0", "--policy", "longest_first", "--out", str(tmp_path), "--quiet"]
    assert main([*args, "--fps", "0"]) == 2
    assert "`fps` must be a positive number" in capsys.readouterr().err
    assert main([*args, "--gif-frames", "1"]) == 2
    assert "`gif_frames` must be at least 2" in capsys.readouterr().err


def test_record_imports_module_attr_from_the_working_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """As ``bench`` and ``evaluate`` do, and as the unknown-module error says: no ``PYTHONPATH=.`` needed."""
    (tmp_path / "my_recorded_agent.py").write_text(
        "from gym4real.elevator.baselines import longest_first\n\n\ndef factory(env):\n    return longest_first(env)\n"
    )
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", ".", str(tmp_path))])
    monkeypatch.delitem(sys.modules, "my_recorded_agent", raising=False)
    args = ["record", "gym4real/elevator-v0", "--policy", "my_recorded_agent:factory", "--out", "videos"]
    assert main([*args, "--max-steps", "5", "--no-mp4", "--quiet"]) == 0, capsys.readouterr().err
    (gif,) = (tmp_path / "videos").glob("*.gif")
    assert len(_frames(gif)) == 6  # the reset and 5 steps
    monkeypatch.delitem(sys.modules, "my_recorded_agent", raising=False)
