"""Contract checks shared by every domain's test suite (installed code, so each suite can import it)."""

from __future__ import annotations

import dataclasses
import json
import pickle
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env


def rollout(env: gym.Env[Any, Any], seed: int, steps: int, options: dict[str, Any] | None = None) -> list[Any]:
    """Reset with ``seed`` and take ``steps`` actions drawn from the action space seeded with ``seed``."""
    obs, _ = env.reset(seed=seed, options=options)
    env.action_space.seed(seed)
    trace: list[Any] = [obs]
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        trace += [obs, reward, terminated, truncated]
        if terminated or truncated:
            break
    return trace


def assert_same_trace(a: list[Any], b: list[Any]) -> None:
    """Assert two rollouts are identical (observations compared element-wise)."""
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        if isinstance(x, dict):
            assert x.keys() == y.keys()
            for k in x:
                np.testing.assert_array_equal(x[k], y[k])
        else:
            np.testing.assert_array_equal(x, y)


def check_contract(env_id: str, steps: int = 50, seeded: bool = True, **kwargs: Any) -> None:
    """The contract of every Gym4ReaL env.

    Gymnasium's ``check_env``; same seed, same trajectory; a fresh env survives a pickle round-trip;
    ``env.spec`` round-trips through JSON; ``info["reward_components"]`` sums to the reward.

    Args:
        env_id: The registered id.
        steps: Steps of each rollout.
        seeded: False for a mode whose randomness ``reset(seed=)`` does not drive (the reference's
            behaviour in some ``fidelity="upstream"`` modes): the same-seed checks are skipped.
        **kwargs: Keyword arguments of ``gymnasium.make``.
    """
    env = gym.make(env_id, **kwargs)
    try:
        if not seeded and env.spec is not None:
            env.unwrapped.spec = dataclasses.replace(env.spec, nondeterministic=True)
        check_env(env.unwrapped, skip_render_check=True)
        if seeded:
            assert_same_trace(rollout(env, 7, steps), rollout(env, 7, steps))
        assert env.spec is not None
        assert gym.spec(env_id).id == env.spec.id
        assert json.loads(env.spec.to_json())["kwargs"] == json.loads(json.dumps(env.spec.kwargs))
        env.reset(seed=3)
        env.action_space.seed(3)
        for _ in range(steps):
            _, reward, terminated, truncated, info = env.step(env.action_space.sample())
            comps = info["reward_components"]
            assert np.isclose(sum(comps.values()), float(reward), rtol=1e-9, atol=1e-9), (comps, reward)
            if terminated or truncated:
                break
    finally:
        env.close()
    fresh = gym.make(env_id, **kwargs)
    clone = pickle.loads(pickle.dumps(fresh))
    if seeded:
        assert_same_trace(rollout(fresh, 11, 5), rollout(clone, 11, 5))
    else:
        rollout(clone, 11, 5)
    fresh.close()
    clone.close()
