"""Videos of a policy acting in an environment: ``gym4real record`` (an MP4 and an animated GIF per episode).

Each frame is the env's ``render_mode="rgb_array"`` frame under a caption with the env, the policy, the
episode, the step and the objective so far (the protocol's objective, the score of ``gym4real bench`` and
``evaluate``; the return where the env has no protocol or its protocol names no objective); an env that
declares ``rgb_array_list`` itself (a robot whose step is a whole pick) is filmed with it: every frame of
each step. The MP4 holds every step and is
written while the episode runs (a year of hourly frames never sits in memory); it needs MoviePy (``pip install
"gym4real-core[video]"``): without it the GIF alone is written, with a :class:`NoMp4Warning` saying so.
The GIF, for documentation, holds at most ``gif_frames`` evenly spaced frames (every k-th step, k
doubling as the episode grows) and is written with Pillow.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import load_env_creator
from PIL import Image

from gym4real.bench.benchmark import policy_name, run_episode
from gym4real.bench.policies import make_policy
from gym4real.bench.progress import ProgressDisplay
from gym4real.core.canvas import captioned
from gym4real.core.errors import ConfigError, Gym4RealError
from gym4real.core.registry import base_env, env_spec, registry


class GifFrames:
    """At most ``limit`` frames of a sequence of unknown length: evenly spaced from its first, and its last.

    Keeps every ``stride``-th frame; when ``limit - 1`` are held, drops every other one and doubles the
    stride. The last frame offered is added at :meth:`save` when the stride skipped it.
    """

    def __init__(self, limit: int) -> None:
        if limit < 2:
            raise ConfigError(f"`gif_frames` must be at least 2, not {limit}")
        self.limit, self.stride, self.seen = limit, 1, 0
        self.frames: list[Image.Image] = []
        self.last: np.ndarray | None = None

    def add(self, frame: np.ndarray) -> None:
        """Offer the next frame."""
        if self.seen % self.stride == 0 and len(self.frames) == self.limit - 1:
            self.frames = self.frames[::2]
            self.stride *= 2
        kept = self.seen % self.stride == 0
        if kept:
            self.frames.append(Image.fromarray(frame))
        self.last = None if kept else frame
        self.seen += 1

    def save(self, path: Path, fps: float) -> None:
        """Write the frames as a looping GIF at ``fps`` frames per second."""
        first, *rest = self.frames
        if self.last is not None:
            rest.append(Image.fromarray(self.last))
        duration = max(20, round(1000 / fps))
        first.save(path, save_all=True, append_images=rest, duration=duration, loop=0, optimize=True)


#: Characters the caption's changing line (seed, step, objective) is padded to, so that every frame of a
#: video keeps the width of the first: a frame narrower than its caption is widened to it.
CAPTION_CHARS = 48

#: Why an MP4 cannot be written, and the fix.
MP4_NEEDS_MOVIEPY = 'writing an MP4 needs MoviePy: `pip install "gym4real-core[video]"`'


class NoMp4Warning(UserWarning):
    """MoviePy is missing: the GIF is written without the MP4."""


def _mp4_writer_class() -> Any:
    """MoviePy's FFmpeg writer, or None when MoviePy is not installed."""
    try:
        from moviepy.video.io.ffmpeg_writer import FFMPEG_VideoWriter
    except ImportError:
        return None
    return FFMPEG_VideoWriter


def recording_mode(env_id: str) -> str:
    """``rgb_array_list`` where the env's class declares it (frames within a step), else ``rgb_array``."""
    entry_point = gym.spec(env_id).entry_point
    creator = load_env_creator(entry_point) if isinstance(entry_point, str) else entry_point
    modes = getattr(creator, "metadata", {}).get("render_modes", ())
    return "rgb_array_list" if "rgb_array_list" in modes else "rgb_array"


def policy_label(policy: str | Callable[[Any], Any]) -> str:
    """The policy's name for captions and file names (``ppo:runs/x/model.zip`` -> ``ppo-model``)."""
    if not isinstance(policy, str):
        return policy_name(policy)
    kind, sep, path = policy.partition(":")
    return f"{kind}-{Path(path).stem}" if sep else policy


def record(
    env_id: str,
    policy: str | Callable[[Any], Any],
    episodes: int = 1,
    seed: int = 0,
    out: str | Path = Path("results") / "videos",
    fps: float | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    max_steps: int | None = None,
    mp4: bool = True,
    gif: bool = True,
    gif_frames: int = 100,
    progress: bool = False,
) -> list[Path]:
    """Run a policy for ``episodes`` seeded episodes and write each as an MP4 and an animated GIF.

    Args:
        env_id: A registered id.
        policy: A baseline name, a trained model ``kind:path``, or a callable ``obs -> action``.
        episodes: Episodes, with seeds ``seed, seed + 1, ...``.
        seed: Seed of the first episode.
        out: Folder of the files ``<env>-<policy>-seed<S>.mp4`` / ``.gif``.
        fps: Frames per second; default the env's ``metadata["render_fps"]``.
        env_kwargs: Keyword arguments of ``gymnasium.make``.
        max_steps: Cut each episode after this many steps (a Gymnasium time limit).
        mp4: Write the MP4 (needs MoviePy; without it, the GIF alone is written and :class:`NoMp4Warning` says
            so).
        gif: Write the GIF.
        gif_frames: Most frames in a GIF.
        progress: Show a progress bar of the steps.

    Returns:
        The paths written.

    Raises:
        Gym4RealError: The MP4 alone is asked for and MoviePy is missing.
    """
    env_spec(env_id)  # a clear error for an unknown or unavailable id
    if episodes < 1:
        raise ConfigError(f"`episodes` must be a positive number, not {episodes}")
    if not (mp4 or gif):
        raise ConfigError("nothing to write: keep the MP4, the GIF or both")
    writer_class = _mp4_writer_class() if mp4 else None
    if mp4 and writer_class is None:
        if not gif:
            raise Gym4RealError(MP4_NEEDS_MOVIEPY)
        warnings.warn(f"{MP4_NEEDS_MOVIEPY}; writing the GIF only", NoMp4Warning, stacklevel=2)
    if fps is not None and not fps > 0:
        raise ConfigError(f"`fps` must be a positive number of frames per second, not {fps}")
    kwargs: dict[str, Any] = {**(env_kwargs or {}), "render_mode": recording_mode(env_id)}
    if max_steps is not None:
        kwargs["max_episode_steps"] = max_steps
    env = gym.make(env_id, **kwargs)
    label = policy_label(policy)
    spec = registry().benchmarks.get(base_env(env_id))
    objective = spec.objective if spec is not None else ()
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    rate = float(fps or env.metadata.get("render_fps") or 4)
    bar = ProgressDisplay(f"{env_id} {label}", unit="steps") if progress else None
    written: list[Path] = []
    try:
        acting = make_policy(env_id, policy, env)
        for i in range(episodes):
            stem = folder / re.sub(r"[^\w.-]+", "_", f"{env_id.split('/')[-1]}-{label}-seed{seed + i}")
            written += _record_episode(
                env, acting, seed + i, stem, rate, writer_class, gif, gif_frames, bar, (env_id, label), objective
            )
    finally:
        env.close()
        if bar is not None:
            bar.close()
    return written


def _record_episode(
    env: gym.Env[Any, Any],
    policy: Callable[[Any], Any],
    seed: int,
    stem: Path,
    fps: float,
    writer_class: Any,
    gif: bool,
    gif_frames: int,
    bar: Any,
    names: tuple[str, str],
    objective: tuple[str, ...] = (),
) -> list[Path]:
    writer = None
    keeper = GifFrames(gif_frames) if gif else None

    def on_step(step: int, total: float) -> None:
        nonlocal writer
        rendered = env.render()
        progress = f"seed {seed}  step {step}  objective {total:.6g}".ljust(CAPTION_CHARS)
        lines = (f"{names[0]}  policy {names[1]}", progress)
        for frame in rendered if isinstance(rendered, list) else [rendered]:
            if not isinstance(frame, np.ndarray):
                raise Gym4RealError(f"`{names[0]}` rendered {type(frame).__name__}, not an rgb_array frame")
            shown = captioned(frame, lines)
            if writer_class is not None:
                if writer is None:
                    size = (shown.shape[1], shown.shape[0])
                    path = str(stem.with_suffix(".mp4"))
                    writer = writer_class(path, size, fps, codec="libx264", pixel_format="yuv420p")
                writer.write_frame(shown)
            if keeper is not None:
                keeper.add(shown)
        if bar is not None and step:
            bar.advance()

    try:
        run_episode(env, policy, seed, None, observer=on_step, objective=objective)
    finally:
        if writer is not None:
            writer.close()
    paths = [stem.with_suffix(".mp4")] if writer_class is not None else []
    if keeper is not None:
        keeper.save(stem.with_suffix(".gif"), fps)
        paths.append(stem.with_suffix(".gif"))
    return paths
