"""DamEnv ``fidelity="upstream"`` against the reference's own numbers (``dam.json``).

Tolerance: none. The upstream lake integrates the same float64 operations in the same order as the
reference, so every reward, every per-episode component sum and every float32 observation is equal
bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

import gym4real
from gym4real.dam import DamEnv

ENV_ID = "gym4real/dam-v0"
# our component names -> the reference's keys of info["weighted_reward"]
NAMES = {
    "overflow": "overflow_reward",
    "starving": "starving_reward",
    "deficit": "daily_deficit_reward",
    "wasted_water": "wasted_water_reward",
    "clipping": "clipping_reward",
}


def test_upstream_baselines_equal_the_reference(golden: Callable[[str], dict[str, Any]]) -> None:
    want = golden("dam")["baselines"]
    result = gym4real.benchmark(ENV_ID, list(want), env_kwargs={"fidelity": "upstream"})
    assert [e["options"]["year"] for e in result.episodes] == want["mean"]["year"]
    for name, ref in want.items():
        assert [len(r) for r in result.rewards[name]] == ref["steps"]
        assert [math.fsum(r) for r in result.rewards[name]] == ref["return"], name
        for ours, theirs in NAMES.items():
            assert result.components[name][ours] == ref["components"][theirs], (name, ours)


def test_upstream_trajectory_equals_the_reference(golden: Callable[[str], dict[str, Any]]) -> None:
    want = golden("dam")["trajectory"]
    env = DamEnv(preset="test", fidelity="upstream")
    env.reset(options={"rewind_profiles": True})  # the first test year of the file, as the reference
    assert env.year == want["year"]
    for action, step in zip(want["actions"], want["steps"], strict=True):
        obs, reward, terminated, truncated, info = env.step(np.array([action]))
        np.testing.assert_array_equal(obs, np.array(step["obs"], dtype=np.float32))
        assert (reward, terminated, truncated, info["release"]) == (
            step["reward"],
            step["terminated"],
            step["truncated"],
            step["release"],
        )
    t = len(want["actions"])
    while not (terminated or truncated):
        obs, reward, terminated, truncated, _ = env.step(np.array([want["after_prefix_action"]]))
        t += 1
    last = want["last"]
    assert t - 1 == last["step"]
    np.testing.assert_array_equal(obs, np.array(last["obs"], dtype=np.float32))  # day 0 and the initial level
    assert (reward, terminated, truncated) == (last["reward"], last["terminated"], last["truncated"])
