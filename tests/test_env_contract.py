"""The contract over every registered environment: check_env, determinism, pickle, vector envs."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import gym4real
from gym4real.bench.policies import make_policy
from gym4real.core.registry import baseline_names
from gym4real.core.testing import check_contract

IDS = gym4real.list_envs(multi_objective=False)  # the vector-reward variants: tests/test_multi_objective_envs.py


@pytest.mark.parametrize("env_id", IDS)
def test_contract(env_id: str) -> None:
    check_contract(env_id, steps=20)


@pytest.mark.parametrize("env_id", gym4real.list_envs())
def test_making_a_listed_id_with_its_defaults_warns_nothing(env_id: str) -> None:
    with warnings.catch_warnings(record=True) as caught:  # the filters in place, as a user's script has them
        gym.make(env_id).close()
    assert [str(w.message) for w in caught] == []


@pytest.mark.parametrize("vector", ["sync", "async"])
@pytest.mark.parametrize("env_id", IDS)
def test_vector_envs_of_four_copies_step(env_id: str, vector: str) -> None:
    fns = [lambda: gym.make(f"gym4real:{env_id}") for _ in range(4)]  # a fresh process imports gym4real
    # spawn, as Ray and other multi-process users do: a fork would inherit this process's renderer and engines
    envs = gym.vector.SyncVectorEnv(fns) if vector == "sync" else gym.vector.AsyncVectorEnv(fns, context="spawn")
    try:
        obs, _ = envs.reset(seed=42)
        envs.action_space.seed(42)
        for _ in range(3):
            obs, rewards, _, _, _ = envs.step(envs.action_space.sample())
        assert rewards.shape == (4,) and np.all(np.isfinite(rewards))
        assert envs.single_observation_space.contains(
            {k: v[0] for k, v in obs.items()} if isinstance(obs, dict) else obs[0]
        )
    finally:
        envs.close()


@pytest.mark.parametrize(("env_id", "baseline"), [(e, b) for e in IDS for b in baseline_names(e)], ids=lambda v: str(v))
def test_every_baseline_acts_inside_the_action_space(env_id: str, baseline: str) -> None:
    env = gym.make(env_id, render_mode=None)
    try:
        policy = make_policy(env_id, baseline, env)
        obs, _ = env.reset(seed=3)
        for _ in range(5):
            action = policy(obs)
            assert _inside(env.action_space, action), f"{baseline} gave {action!r} outside {env.action_space}"
            obs, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break
    finally:
        env.close()


def _inside(space: gym.Space, action: object) -> bool:
    """In the space; a float Box also takes a wider float (a baseline may keep float64 precision)."""
    if isinstance(space, gym.spaces.Box) and np.issubdtype(np.asarray(action).dtype, np.floating):
        action = np.asarray(action).astype(space.dtype)
    return space.contains(action)
