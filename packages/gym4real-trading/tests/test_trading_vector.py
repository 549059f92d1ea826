from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import gym4real  # noqa: F401
from gym4real.core.testing import compare_vector_with_sync
from gym4real.trading.env import TradingEnv
from gym4real.trading.vector import TradingVectorEnv


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_batched_copies_follow_the_single_env_step_by_step(fidelity: str) -> None:
    n = 5
    vec = gym.make_vec("gym4real/trading-v0", num_envs=n, vectorization_mode="vector_entry_point", fidelity=fidelity)
    singles = [TradingEnv(fidelity=fidelity) for _ in range(n)]
    obs, _ = vec.reset(seed=21)
    single_obs = [e.reset(seed=21 + i)[0] for i, e in enumerate(singles)]
    rng = np.random.default_rng(1)
    done = False
    steps = 0
    while not done:
        np.testing.assert_array_equal(obs, np.stack(single_obs))
        actions = rng.integers(0, 3, size=n)
        obs, rewards, terminated, truncated, info = vec.step(actions)
        outs = [e.step(int(a)) for e, a in zip(singles, actions, strict=True)]
        single_obs = [o[0] for o in outs]
        np.testing.assert_allclose(rewards, [o[1] for o in outs], rtol=0, atol=1e-9)
        np.testing.assert_array_equal(terminated, [o[2] for o in outs])
        np.testing.assert_array_equal(truncated, [o[3] for o in outs])
        np.testing.assert_allclose(info["reward_components"]["fees"], [o[4]["reward_components"]["fees"] for o in outs])
        done = bool(truncated.all())
        steps += 1
    assert steps == singles[0].n_steps
    np.testing.assert_allclose(vec.unwrapped.cum_pnl, [e.cum_pnl for e in singles])


def test_bad_actions_are_refused() -> None:
    vec = TradingVectorEnv(2)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="not in the action space"):
        vec.step(np.array([1, 5]))


@pytest.mark.parametrize(
    ("kwargs", "num_envs", "steps"),
    [
        ({}, 4, 30),
        ({"fidelity": "upstream"}, 4, 30),
        ({"sequential": True}, 4, 30),
        ({"max_episode_steps": 5}, 4, 30),
    ],
)
def test_native_vector_env_is_a_drop_in_for_sync_vector_env(kwargs: dict[str, Any], num_envs: int, steps: int) -> None:
    """Same seeds and actions give the trajectories of ``SyncVectorEnv`` of the single env, across autoresets.

    Float P&L: equal within 1e-9 relative.
    """
    result = compare_vector_with_sync("gym4real/trading-v0", num_envs, steps, seed=3, rtol=1e-09, **kwargs)
    assert (result.episode_ends >= 2).all()


def test_days_drawn_ahead_are_the_single_envs_days_across_refills(monkeypatch: pytest.MonkeyPatch) -> None:
    """With 2 days drawn per call, 30 steps (4 episodes) refill every copy's draws twice: still SyncVectorEnv's days."""
    monkeypatch.setattr("gym4real.trading.vector.DRAWS_AT_ONCE", 2)
    result = compare_vector_with_sync("gym4real/trading-v0", 3, 30, seed=4)
    assert (result.episode_ends >= 3).all()


def test_reset_options_pick_each_copys_day_like_the_single_env() -> None:
    vec = TradingVectorEnv(3)
    single = TradingEnv()
    days = [single.days[5], single.days[2].isoformat(), 7]
    obs, info = vec.reset(seed=1, options={"day": days})
    for i, day in enumerate(days):
        single_obs, single_info = single.reset(seed=1 + i, options={"day": day})
        np.testing.assert_array_equal(obs[i], single_obs)
        assert single.days[info["day"][i]].isoformat() == single_info["day"]
    assert info["_day"].all()
    # the options draw nothing: the next days are those the seeded single envs draw first
    _, info = vec.reset()
    for i in range(3):
        single.reset(seed=1 + i, options={"day": 0})
        _, single_info = single.reset()
        assert single.days[info["day"][i]].isoformat() == single_info["day"]
    _, info = vec.reset(options={"day": single.days[4]})  # one day for every copy
    assert (info["day"] == 4).all()


def test_bad_reset_options_are_refused_naming_them() -> None:
    vec = TradingVectorEnv(2)
    with pytest.raises(ValueError, match="unknown reset options"):
        vec.reset(options={"year": 2020})
    with pytest.raises(ValueError, match="one value or 2"):
        vec.reset(options={"day": [0, 1, 2]})
    with pytest.raises(ValueError, match="out of range"):
        vec.reset(options={"day": 10**6})


def test_step_info_carries_gymnasiums_masks() -> None:
    vec = TradingVectorEnv(2)
    vec.reset(seed=0)
    _, _, _, _, info = vec.step(np.array([0, 2]))
    assert info["_reward_components"].tolist() == [True, True]
    assert info["reward_components"]["_pnl"].tolist() == [True, True]
    assert info["reward_components"]["_fees"].tolist() == [True, True]
