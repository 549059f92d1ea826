"""Evaluate your algorithm: train Stable-Baselines3's A2C on two gym4real environments, then score it.

``python examples/evaluate_a2c.py [--steps 5000] [--seeds 0,1] [--out results/evaluate-a2c]`` trains one
A2C agent per seed on the trading and the water-distribution environments (their training presets),
saves each model, and runs
``gym4real.evaluate`` on the two test protocols: per environment the agent's IQM and its probability of
improvement over the reference agents and the best rule-based baseline, and its suite score (0 = random,
1 = the best rule-based baseline; trading, whose two anchors its test days cannot tell apart, has no such
scale and stays out of it). The docs tutorial ``docs/evaluate.md`` walks through it.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3 import A2C

import gym4real

#: The environments and the ``make()`` arguments of their training episodes (never the test preset).
TRAINING: dict[str, dict[str, Any]] = {
    "gym4real/trading-v0": {"preset": "train"},
    "gym4real/wds-v0": {"preset": "train"},
}


def training_env(env_id: str) -> gym.Env[Any, Any]:
    """The training environment; a continuous action space (the dam's, the microgrid's) is rescaled to [-1, 1].

    gym4real's model loader maps the actions of such a model back onto the environment's bounds, as
    ``gym4real train`` does, so a model of a bounded Box must be trained on [-1, 1].
    """
    env = gym.make(env_id, **TRAINING[env_id])
    if isinstance(env.action_space, gym.spaces.Box):
        env = gym.wrappers.RescaleAction(env, np.float32(-1.0), np.float32(1.0))
    return env


def train(env_id: str, seed: int, steps: int, folder: Path) -> Path:
    """Train A2C for ``steps`` steps with ``seed``; save ``folder/model.zip``."""
    env = training_env(env_id)
    policy = "MultiInputPolicy" if isinstance(env.observation_space, gym.spaces.Dict) else "MlpPolicy"
    model = A2C(policy, env, seed=seed, device="cpu")
    model.learn(total_timesteps=steps)
    folder.mkdir(parents=True, exist_ok=True)
    model.save(folder / "model.zip")
    env.close()
    return folder / "model.zip"


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """Train, evaluate, print the comparison; return the content of ``score.json``."""
    parser = argparse.ArgumentParser(description="Train A2C on two gym4real environments and score it.")
    parser.add_argument("--steps", type=int, default=5000, help="training steps per environment and seed")
    parser.add_argument("--seeds", default="0,1", help="training seeds, comma-separated")
    parser.add_argument("--out", default="results/evaluate-a2c", help="output folder")
    args = parser.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",")]
    out = Path(args.out)
    for env_id in TRAINING:
        for seed in seeds:
            train(env_id, seed, args.steps, out / "models" / env_id.split("/")[1] / f"seed{seed}")
    # one model per env and seed: {env} and {seed} are filled in by evaluate
    agent = f"sb3:a2c:{out}/models/{{env}}/seed{{seed}}/model.zip"
    evaluation = gym4real.evaluate({"a2c": agent}, envs=list(TRAINING), seeds=seeds, out=out / "score")
    print(evaluation.table())
    score: dict[str, Any] = evaluation.score()
    aggregate = score["aggregate"]
    print(f"suite score of a2c: IQM {aggregate['iqm']:.3f} [{aggregate['low']:.3f}, {aggregate['high']:.3f}]")
    return score


if __name__ == "__main__":
    main()
