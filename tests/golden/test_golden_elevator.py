"""ElevatorEnv ``fidelity="upstream"`` against the reference's own numbers (``elevator.json``).

What the reference makes reproducible: the arrivals are a function of ``floors.seed`` alone (1234 in the
evaluation), episode after episode. What it does not: the initial cabin position comes from the
observation space's own generator, which the reference never seeds, so two runs of its evaluation
differ. ``regen.py`` seeds that sub-space with 1234 through Gymnasium's space API, which is what our
upstream mode does; with that the whole evaluation is reproducible and recorded.

Tolerance: none. Rewards are integers; the arrivals, start positions, returns and components are
equal, and so is every observation of the trajectory.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from gym4real.elevator import evaluation
from gym4real.elevator.baselines import longest_first, shortest_first

ENV_ID = "gym4real/elevator-v0"
KWARGS = {"preset": "test", "fidelity": "upstream"}
BASELINES = {"longest_first": longest_first, "shortest_first": shortest_first}


@pytest.mark.parametrize("name", sorted(BASELINES))
def test_upstream_baselines_equal_the_reference(golden: Callable[[str], dict[str, Any]], name: str) -> None:
    want = golden("elevator")["baselines"][name]
    env = gym.make(ENV_ID, **KWARGS)
    policy = BASELINES[name](env)
    got: dict[str, list[Any]] = {"start": [], "arrived": [], "steps": [], "return": [], "delivery": [], "waiting": []}
    for ep in evaluation.test_episodes(KWARGS):
        obs, info = env.reset(seed=ep["seed"], options=ep["options"])
        got["start"].append(info["position_m"])
        rewards, delivery, waiting, done = [], 0.0, 0.0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(policy(obs))
            rewards.append(reward)
            delivery += info["reward_components"]["delivery"]
            waiting += info["reward_components"]["waiting"]
            done = terminated or truncated
        got["arrived"].append(env.unwrapped.counts()["arrived"])
        got["steps"].append(len(rewards))
        got["return"].append(math.fsum(rewards))
        got["delivery"].append(delivery)
        got["waiting"].append(waiting)
    assert got["start"] == want["start_position_m"]
    assert got["arrived"] == [sum(a) for a in want["arrivals_per_floor"]]
    assert got["steps"] == want["steps"]
    assert got["return"] == want["return"]
    assert got["delivery"] == want["components"]["delivery"]
    assert got["waiting"] == want["components"]["waiting"]


def test_upstream_trajectory_equals_the_reference(golden: Callable[[str], dict[str, Any]]) -> None:
    want = golden("elevator")["trajectory"]
    env = gym.make(ENV_ID, **KWARGS)
    obs, _ = env.reset()
    _assert_obs(obs, want["steps"][0]["obs"])
    for action, step in zip(want["actions"], want["steps"][1:], strict=True):
        obs, reward, terminated, truncated, _ = env.step(action)
        _assert_obs(obs, step["obs"])
        assert (reward, terminated, truncated) == (step["reward"], step["terminated"], step["truncated"])


def _assert_obs(obs: dict[str, Any], want: dict[str, Any]) -> None:
    assert obs.keys() == want.keys()
    for key, value in want.items():
        np.testing.assert_array_equal(obs[key], value, err_msg=key)
