from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import gym4real  # noqa: F401
from gym4real.elevator import ElevatorEnv
from gym4real.elevator.vector import ElevatorVectorEnv


def test_batched_copies_follow_the_single_env_step_by_step() -> None:
    n, steps = 6, 700
    vec = gym.make_vec("gym4real/elevator-v0", num_envs=n, vectorization_mode="vector_entry_point", duration=steps)
    singles = [ElevatorEnv(duration=steps) for _ in range(n)]
    obs, _ = vec.reset(seed=10)
    single_obs = [e.reset(seed=10 + i)[0] for i, e in enumerate(singles)]
    rng = np.random.default_rng(0)
    for t in range(steps):
        for i, o in enumerate(single_obs):
            for key in o:
                assert np.array_equal(obs[key][i], o[key]), (t, i, key)
        actions = rng.integers(0, 3, size=n)
        obs, rewards, terminated, truncated, _ = vec.step(actions)
        outs = [e.step(int(a)) for e, a in zip(singles, actions, strict=True)]
        single_obs = [o[0] for o in outs]
        np.testing.assert_array_equal(rewards, [o[1] for o in outs])
        np.testing.assert_array_equal(truncated, [o[3] for o in outs])
        assert not terminated.any()
    assert truncated.all()
    np.testing.assert_array_equal(vec.unwrapped.delivered, [e.delivered for e in singles])
    np.testing.assert_array_equal(vec.unwrapped.turned_away, [e.turned_away for e in singles])
    obs, rewards, *_ = vec.step(np.ones(n, dtype=int))  # next-step autoreset
    assert np.all(rewards == 0) and np.all(obs["n_passengers"] == 0)


def test_batched_env_rejects_upstream_and_bad_actions() -> None:
    with pytest.raises(ValueError, match="corrected"):
        ElevatorVectorEnv(2, fidelity="upstream")
    vec = ElevatorVectorEnv(2)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="actions must be"):
        vec.step(np.array([0, 3]))
