"""Steps per second of every installed Gym4ReaL environment.

For each id: the raw env (``env.unwrapped``) and the env from ``gymnasium.make`` (with its wrappers), one
copy and a ``SyncVectorEnv`` of 8; random actions drawn beforehand; warm (one episode first); median of
several timed runs. Reports microseconds per step, steps per second and seconds per episode; for envs
with a native batched ``VectorEnv`` (``vector_entry_point``), its steps per second with 1024 copies.

    python benchmarks/bench_envs.py [--ids gym4real/dam-v0,...] [--repeats 5] [--budget 1.0] [--kwargs JSON]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
from report import report  # benchmarks/report.py (the script's folder is on sys.path)

import gym4real


def _steps_loop(env: gym.Env[Any, Any], actions: list[Any]) -> tuple[int, int]:
    """Step through ``actions``, resetting at episode ends; return (steps, finished episodes)."""
    episodes = 0
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            episodes += 1
            env.reset()
    return len(actions), episodes


def _median_time(run: Callable[[], Any], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _episode_length(env: gym.Env[Any, Any], seed: int) -> tuple[int, float]:
    env.reset(seed=seed)
    env.action_space.seed(seed)
    n, done = 0, False
    t0 = time.perf_counter()
    while not done:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        n += 1
        done = terminated or truncated
    return n, time.perf_counter() - t0


def bench_env(env_id: str, repeats: int, budget: float, kwargs: dict[str, Any]) -> dict[str, Any]:
    env = gym.make(env_id, **kwargs)
    raw = env.unwrapped
    length, first = _episode_length(env, 0)  # warm-up and episode length
    per_step = first / max(length, 1)
    n = max(10, min(200_000, int(budget / max(per_step, 1e-7))))
    env.action_space.seed(1)
    actions = [env.action_space.sample() for _ in range(n)]
    row: dict[str, Any] = {"env": env_id, "episode_steps": length}
    for label, target in (("raw", raw), ("make", env)):
        target.reset(seed=1)
        t = _median_time(lambda target=target: _steps_loop(target, actions), repeats)
        row[f"{label}_us_per_step"] = t / n * 1e6
    row["raw_steps_per_s"] = 1e6 / row["raw_us_per_step"]
    row["raw_episode_s"] = row["raw_us_per_step"] * length / 1e6
    env.close()

    vec = gym.vector.SyncVectorEnv([lambda: gym.make(env_id, **kwargs) for _ in range(8)])
    vec.reset(seed=2)
    vec.action_space.seed(2)
    m = max(5, n // 8)
    batch = [vec.action_space.sample() for _ in range(m)]

    def run_vec() -> None:
        for a in batch:
            vec.step(a)

    row["vec8_steps_per_s"] = 8 * m / _median_time(run_vec, repeats)
    vec.close()
    row["native1024_steps_per_s"] = float("nan")
    if gym.spec(env_id).vector_entry_point:  # the env's own batched VectorEnv
        try:
            native = gym.make_vec(env_id, num_envs=1024, vectorization_mode="vector_entry_point", **kwargs)
        except ValueError as exc:  # a mode the batched env does not cover (upstream fidelity)
            print(f"# {env_id}: no native vector env here: {exc}")
            return row
        native.reset(seed=3)
        native.action_space.seed(3)
        steps = [native.action_space.sample() for _ in range(200)]

        def run_native() -> None:
            for a in steps:
                native.step(a)

        row["native1024_steps_per_s"] = 1024 * len(steps) / _median_time(run_native, repeats)
        native.close()
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ids", default="", help="comma-separated ids (default: every installed env)")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--budget", type=float, default=1.0, help="seconds of stepping per timed run")
    parser.add_argument("--kwargs", default="{}", help="JSON make() kwargs applied to every env")
    parser.add_argument("--json", help="also write the rows to this JSON file")
    args = parser.parse_args()
    ids = [i for i in args.ids.split(",") if i] or gym4real.list_envs(multi_objective=False)
    rows = [bench_env(i, args.repeats, args.budget, json.loads(args.kwargs)) for i in ids]
    cols = [
        "env",
        "raw_us_per_step",
        "make_us_per_step",
        "raw_steps_per_s",
        "vec8_steps_per_s",
        "native1024_steps_per_s",
        "episode_steps",
        "raw_episode_s",
    ]
    report(rows, cols, 4, args.json)


if __name__ == "__main__":
    main()
