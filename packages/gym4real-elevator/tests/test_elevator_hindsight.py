from __future__ import annotations

import itertools

import gymnasium as gym
import numpy as np
import pytest

from gym4real.bench.policies import make_policy

pytest.importorskip("numba")

from gym4real.elevator.hindsight import ElevatorHindsight

ENV = "gym4real/elevator-v0"


def _return(env: gym.Env, seed: int, actions: tuple[int, ...]) -> float:
    env.reset(seed=seed)
    total = 0.0
    for a in actions:
        total += float(env.step(a)[1])
    return total


def _replay(env: gym.Env, policy: ElevatorHindsight, seed: int) -> float:
    obs, _ = env.reset(seed=seed)
    policy.reset(seed)
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, _ = env.step(policy(obs))
        total += float(reward)
        done = terminated or truncated
    return total


def test_the_plan_is_the_best_of_every_action_sequence_of_a_short_busy_episode() -> None:
    """Eight seconds with busy floors and a cabin starting between floors: all 3^8 sequences, through the env."""
    env = gym.make(ENV, duration=8, floors={"lambda_min": 0.5, "lambda_max": 1.0})
    for seed in (0, 7):
        best = max(_return(env, seed, seq) for seq in itertools.product(range(3), repeat=8))
        policy = ElevatorHindsight(env, cache=False)
        assert _replay(env, policy, seed) == pytest.approx(best)
        assert policy.planned_objectives[-1] == pytest.approx(best)


def test_upstream_the_replay_scores_the_planned_return() -> None:
    """Upstream, a seed does not repeat an episode (its rates come from one stream), so no brute force: the
    plan, made from the episode's own arrivals table, replays to exactly the return it planned."""
    env = gym.make(ENV, duration=300, fidelity="upstream")
    policy = ElevatorHindsight(env, cache=False)
    for _ in range(2):
        assert _replay(env, policy, None) == pytest.approx(policy.planned_objectives[-1])


def test_the_plan_beats_the_rule_based_dispatchers_on_a_test_episode() -> None:
    env = gym.make(ENV, preset="test", duration=600)
    seed = 1234
    upper = _replay(env, ElevatorHindsight(env, cache=False), seed)
    for name in ("longest_first", "shortest_first", "random"):
        policy = make_policy(ENV, name, env)
        obs, _ = env.reset(seed=seed)
        getattr(policy, "reset", lambda s: None)(seed)
        total, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(policy(obs))
            total += float(reward)
            done = terminated or truncated
        assert upper >= total, name
    assert np.isfinite(upper)
