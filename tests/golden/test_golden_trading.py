"""TradingEnv ``fidelity="upstream"`` against the reference's own numbers (``trading.json``).

Both read the synthetic HistData tick files of ``synthetic_ticks.py`` (the reference ships no market
data): 2022, nine January sessions with short gaps (forward-filled), one with a 12-minute gap (dropped),
ticks outside the session and a weekend evening.

Tolerances: kept days, episode lengths, flags, rewards, daily returns and the fitted scaler's bounds are
exact. Observations: ``atol`` = 2.2e-16 (one ulp at 1; largest difference seen 1.1e-16, in 154 of the 189
recorded values): the 60 lagged returns are equal, but sklearn's ``MinMaxScaler`` scales them as
``x * scale_ + min_`` and ours as ``(x - min) / (max - min)``, one rounding apart.

The reference caches the processed minutes as a CSV in the data folder and reads that back, on later
constructions, with pandas' default float parser, which is not correctly rounded; ``regen.py`` removes the
cache after each construction, so every reference env read the tick files (with its cache, rewards move
by up to 2.2e-11 = 1e5 x one ulp of a price).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from gym4real.trading import TradingEnv, evaluation, features, processing
from gym4real.trading.baselines import buy_and_hold, sell_and_hold

BASELINES = {"buy_and_hold": buy_and_hold, "sell_and_hold": sell_and_hold}
OBS_ATOL = float(np.finfo(np.float64).eps)


@pytest.fixture
def kwargs(histdata_ticks: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """The reference's world_test.yaml on the synthetic year; our cache in a temporary folder."""
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    processing._memo.clear()
    features._memo.clear()
    year = {"years": [2022]}
    return {
        "preset": "paper_test",
        "fidelity": "upstream",
        "source": {"path": str(histdata_ticks), "kind": "histdata_tick"},
        "splits": {"train": year, "validation": year, "test": year},
    }


@pytest.mark.parametrize("persistence", [5, 1])
def test_upstream_baselines_match_the_reference(
    golden: Callable[[str], dict[str, Any]], kwargs: dict[str, Any], persistence: int
) -> None:
    want = golden("trading")[f"persistence_{persistence}"]
    kwargs = {**kwargs, "persistence": persistence}
    episodes = evaluation.test_episodes(kwargs)
    assert [e["options"]["day"] for e in episodes] == want["days"]
    for name, ref in want["baselines"].items():
        env = TradingEnv(**kwargs)
        policy = BASELINES[name](env)
        steps, returns = [], []
        for ep in episodes:
            obs, _ = env.reset(seed=ep["seed"], options=ep["options"])
            rewards, done = [], False
            while not done:
                obs, reward, terminated, truncated, info = env.step(policy(obs))
                assert reward == info["reward_components"]["pnl"] + info["reward_components"]["fees"]
                rewards.append(reward)
                done = terminated or truncated
            steps.append(len(rewards))
            returns.append(math.fsum(rewards))
        assert steps == ref["steps"], name
        assert returns == ref["return"], name


def test_upstream_trajectory_matches_the_reference(
    golden: Callable[[str], dict[str, Any]], kwargs: dict[str, Any]
) -> None:
    want = golden("trading")["trajectory"]
    env = TradingEnv(**kwargs)
    obs, _ = env.reset(options={"day": want["day"]})
    scaler = env.get_scaler()
    assert (scaler.data_min_[0], scaler.data_max_[0]) == (want["scaler_min_first"], want["scaler_max_first"])
    observations, rewards, terminated, truncated = [obs], [], [], []
    for k, action in enumerate(want["actions"]):
        obs, reward, term, trunc, _ = env.step(action)
        rewards.append(reward)
        terminated.append(term)
        truncated.append(trunc)
        if k == 0 or term or trunc:
            observations.append(obs)
    np.testing.assert_allclose(observations, want["obs"], rtol=0, atol=OBS_ATOL)
    assert rewards == want["reward"]
    assert (terminated, truncated) == (want["terminated"], want["truncated"])
