"""Milliseconds per ``rgb_array`` frame of every Gym4ReaL env, and what rendering costs ``step()``.

For each id: one seeded episode of random actions (cut at ``--steps``) with ``render()`` after every step;
reports the median and 95th percentile of the time of ``render()`` (the env's own frame, no caption), the
frame size, and the raw ``step()`` time with ``render_mode=None`` and with ``render_mode="rgb_array"``
when ``render()`` is never called (the cost of recording what a frame needs), medians of ``--repeats``
timed runs. The robofeeder envs render their top-down view inside ``step()`` (it is the observation),
so their ``render()`` returns a copy of it; ``--camera angled_side_view`` times a render of its own.

    python benchmarks/bench_render.py [--ids gym4real/dam-v0,...] [--steps 400] [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

import gymnasium as gym
import numpy as np
from report import report  # benchmarks/report.py (the script's folder is on sys.path)

import gym4real


def _frame_times(env_id: str, steps: int, kwargs: dict[str, Any]) -> tuple[list[float], tuple[int, ...]]:
    env = gym.make(env_id, render_mode="rgb_array", **kwargs)
    raw = env.unwrapped
    raw.reset(seed=0)
    env.action_space.seed(0)
    times, shape = [], ()
    for _ in range(steps):
        _, _, terminated, truncated, _ = raw.step(env.action_space.sample())
        t0 = time.perf_counter()
        frame = raw.render()
        times.append(time.perf_counter() - t0)
        shape = np.shape(frame)
        if terminated or truncated:
            raw.reset()
    env.close()
    return times, shape


def _step_us(env_id: str, render_mode: str | None, steps: int, repeats: int, kwargs: dict[str, Any]) -> float:
    env = gym.make(env_id, render_mode=render_mode, **kwargs)
    raw = env.unwrapped
    env.action_space.seed(1)
    actions = [env.action_space.sample() for _ in range(steps)]

    def run() -> float:
        raw.reset(seed=1)
        t0 = time.perf_counter()
        for a in actions:
            _, _, terminated, truncated, _ = raw.step(a)
            if terminated or truncated:
                raw.reset()
        return time.perf_counter() - t0

    run()  # warm
    t = statistics.median(run() for _ in range(repeats))
    env.close()
    return t / steps * 1e6


def bench(env_id: str, steps: int, repeats: int, kwargs: dict[str, Any]) -> dict[str, Any]:
    times, shape = _frame_times(env_id, steps, kwargs)
    ms = np.asarray(times) * 1e3
    return {
        "env": env_id,
        "frame": "x".join(map(str, shape)),
        "render_ms_median": float(np.median(ms)),
        "render_ms_p95": float(np.percentile(ms, 95)),
        "step_us_none": _step_us(env_id, None, steps, repeats, kwargs),
        "step_us_rgb_array": _step_us(env_id, "rgb_array", steps, repeats, kwargs),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ids", default="", help="comma-separated ids (default: every installed env)")
    parser.add_argument("--steps", type=int, default=400, help="steps (and frames) per env")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--camera", default=None, help="robofeeder render_camera (default: the env's)")
    parser.add_argument("--json", help="also write the rows to this JSON file")
    args = parser.parse_args()
    ids = [i for i in args.ids.split(",") if i] or gym4real.list_envs()
    rows = []
    for env_id in ids:
        kwargs = {"render_camera": args.camera} if args.camera and "robofeeder" in env_id else {}
        rows.append(bench(env_id, args.steps, args.repeats, kwargs))
    cols = ["env", "frame", "render_ms_median", "render_ms_p95", "step_us_none", "step_us_rgb_array"]
    report(rows, cols, 3, args.json)


if __name__ == "__main__":
    main()
