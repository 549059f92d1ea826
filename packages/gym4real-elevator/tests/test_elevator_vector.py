from __future__ import annotations

import importlib.util
import sys
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import gym4real  # noqa: F401
from gym4real.core.testing import compare_vector_with_sync
from gym4real.elevator import ElevatorEnv, arrivals
from gym4real.elevator.vector import ElevatorVectorEnv

NEEDS_NUMBA = pytest.mark.skipif(importlib.util.find_spec("numba") is None, reason="numba (extra fast) not installed")


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
    for bad in (0, 2.5, True):
        with pytest.raises(ValueError, match="max_episode_steps must be a positive int"):
            ElevatorVectorEnv(2, max_episode_steps=bad)
    assert ElevatorVectorEnv(2, max_episode_steps=-1).max_episode_steps is None  # make()'s "no TimeLimit"
    vec = ElevatorVectorEnv(2)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="not in the action space"):
        vec.step(np.array([0, 3]))


@pytest.mark.parametrize(
    ("kwargs", "num_envs", "steps"),
    [
        ({"duration": 60}, 4, 200),
        ({"duration": 60, "max_episode_steps": 7}, 4, 60),
    ],
)
@pytest.mark.parametrize("compiled", [pytest.param(True, marks=NEEDS_NUMBA), False])
def test_native_vector_env_is_a_drop_in_for_sync_vector_env(
    kwargs: dict[str, Any], num_envs: int, steps: int, compiled: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Same seeds and actions give the trajectories of ``SyncVectorEnv`` of the single env, across autoresets,
    with the compiled step of the copies (numba) and with the numpy one (what runs without numba).

    Discrete dynamics: bit for bit.
    """
    made = []
    original = ElevatorVectorEnv.__init__

    def init(self: ElevatorVectorEnv, *args: Any, **kw: Any) -> None:
        original(self, *args, compiled=compiled, **kw)
        made.append(self)

    monkeypatch.setattr(ElevatorVectorEnv, "__init__", init)
    result = compare_vector_with_sync("gym4real/elevator-v0", num_envs, steps, seed=3, rtol=0.0, **kwargs)
    assert (result.episode_ends >= 2).all()
    assert [vec._kernel is not None for vec in made] == [compiled]


def test_compiled_true_without_numba_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "gym4real.elevator.vector_kernel", None)  # as if numba were missing
    with pytest.raises(ImportError, match=r"gym4real-elevator\[fast\]"):
        ElevatorVectorEnv(2, compiled=True)
    assert ElevatorVectorEnv(2)._kernel is None  # the default falls back to numpy


@pytest.mark.parametrize("compiled", [pytest.param(True, marks=NEEDS_NUMBA), False])
@pytest.mark.parametrize(
    ("rates", "cap"), [([0.01, 0.05, 0.1, 0.0], 2), ([0.5, 3.0, 9.99], 1000), ([0.2, 12.0, 40.0], 100)]
)
def test_arrivals_are_numpys_poisson_draws_from_the_episode_generator(
    compiled: bool, rates: list[float], cap: int
) -> None:
    """Compiled (numpy's method below rate 10, numpy itself from 10 on) or numpy: ``rng.poisson`` per floor."""
    mine, reference = np.random.default_rng(7), np.random.default_rng(7)
    counts = arrivals.corrected_arrivals(mine, np.array(rates), 3000, cap, compiled=compiled)
    expected = np.minimum(np.stack([reference.poisson(rate, size=3000) for rate in rates], axis=1), cap)
    np.testing.assert_array_equal(counts, expected)
    assert mine.random() == reference.random()  # the generator advanced as numpy's draws advance it


def test_compiled_arrivals_without_numba_name_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "gym4real.elevator.arrivals_kernel", None)  # as if numba were missing
    arrivals._compiled.cache_clear()
    try:
        with pytest.raises(ImportError, match=r"gym4real-elevator\[fast\]"):
            arrivals.corrected_arrivals(np.random.default_rng(0), np.array([0.1]), 10, 2, compiled=True)
        counts = arrivals.corrected_arrivals(np.random.default_rng(0), np.array([0.1]), 10, 2)  # numpy instead
        np.testing.assert_array_equal(counts[:, 0], np.minimum(np.random.default_rng(0).poisson(0.1, 10), 2))
    finally:
        arrivals._compiled.cache_clear()
