"""Where RL training time goes: the environment or the learner, per training preset.

For each preset, a short training run (the preset's settings, ``--steps`` environment steps, no evaluation
until the end) is timed, and the same number of steps of the training environment alone (the trainer's
vector env for PPO/DQN, one env for Q-learning/SARSA, random actions). Times are CPU seconds of this
process (``time.process_time``), so that a shared machine's load does not count; both are reported as
environment steps per CPU second, with the environment's share of the training time. For the tabular
presets the compiled loop (after its compilation) and the Python loop are both timed.

    python benchmarks/bench_training.py [--presets gym4real/dam-v0:ppo:paper,...] [--steps 20000]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import gym4real
from gym4real.core.rl.plan import presets
from gym4real.core.rl.presets import load_preset

DEFAULT = (
    "gym4real/elevator-v0:qlearning:paper,gym4real/elevator-v0:sarsa:paper,gym4real/dam-v0:ppo:paper,"
    "gym4real/trading-v0:ppo:hourly,gym4real/trading-v0:dqn:hourly"
)


def _env_only(env_id: str, hp: dict[str, Any], steps: int) -> float:
    """CPU seconds of ``steps`` environment steps as the trainer makes its env (random actions)."""
    if hp["algo"] in ("qlearning", "sarsa"):
        env = gym.make(env_id, **hp["env_kwargs"])
        env.reset(seed=0)
        actions = np.random.default_rng(0).integers(env.action_space.n, size=steps)
        start = time.process_time()
        for a in actions:
            *_, terminated, truncated, _ = env.step(int(a))
            if terminated or truncated:
                env.reset()
        return time.process_time() - start
    from stable_baselines3.common.env_util import make_vec_env

    from gym4real.core.rl.sb3 import _rescale

    venv = make_vec_env(
        env_id,
        n_envs=hp["n_envs"],
        seed=0,
        env_kwargs={"render_mode": None, **hp["env_kwargs"]},
        wrapper_class=_rescale,
    )
    venv.reset()
    venv.action_space.seed(0)
    actions = [
        np.array([venv.action_space.sample() for _ in range(venv.num_envs)]) for _ in range(steps // venv.num_envs)
    ]
    start = time.process_time()
    for a in actions:
        venv.step(a)
    return time.process_time() - start


def _train(env_id: str, hp: dict[str, Any], steps: int, compiled: bool | None) -> tuple[float, int]:
    """CPU seconds and environment steps of a short training run with the preset's settings."""
    with tempfile.TemporaryDirectory() as tmp:
        start = time.process_time()
        if hp["algo"] in ("qlearning", "sarsa"):
            from gym4real.core.rl.tabular import train_tabular

            horizon = gym.make(env_id, **hp["env_kwargs"]).unwrapped.config.duration
            short = {**hp, "episodes": max(1, steps // horizon), "eval_every": 10**9, "eval_episodes": 1}
            _, counts = train_tabular(env_id, short, 0, Path(tmp), compiled=compiled)
        else:
            from gym4real.core.rl.sb3 import train_sb3

            short = {**hp, "total_timesteps": steps, "eval_freq": 10**9, "eval_episodes": 1}
            _, counts = train_sb3(env_id, short, 0, Path(tmp))
        return time.process_time() - start, counts["train"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default=DEFAULT, help="comma-separated ENV:ALGO:PRESET")
    parser.add_argument("--steps", type=int, default=20_000, help="environment steps per measurement")
    args = parser.parse_args()
    gym4real.register_envs()
    print("preset | loop | train steps/CPU s | env-only steps/CPU s | env share of training")
    print("--- | --- | --- | --- | ---")
    for item in args.presets.split(","):
        env_id, algo, preset = item.split(":")
        if preset not in presets(env_id, "paper").values() and preset not in ("paper", "smoke"):
            raise SystemExit(f"unknown preset {item}")
        hp = load_preset(env_id, algo, preset)
        env_cpu = _env_only(env_id, hp, args.steps)
        loops = [True, False] if algo in ("qlearning", "sarsa") else [None]
        if True in loops:
            _train(env_id, hp, 1, True)  # compile the loop first (numba)
        for compiled in loops:
            cpu, n = _train(env_id, hp, args.steps, compiled)
            loop = {True: "compiled", False: "python", None: "sb3"}[compiled]
            share = "- (compiled dynamics)" if compiled else f"{env_cpu / args.steps * n / cpu:.0%}"
            print(f"{item} | {loop} | {n / cpu:.4g} | {args.steps / env_cpu:.4g} | {share}")


if __name__ == "__main__":
    main()
