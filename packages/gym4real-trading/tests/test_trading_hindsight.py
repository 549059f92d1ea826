from __future__ import annotations

import itertools
from pathlib import Path

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest

import gym4real
from gym4real.trading.evaluation import test_episodes as protocol_episodes
from gym4real.trading.hindsight import hindsight, plan_day

ENV = "gym4real/trading-v0"
PAPER = Path(__file__).resolve().parents[3] / "docs" / "results" / "trading-v0-paper" / "episodes.csv"


def _play(env: gym.Env, actions: tuple[int, ...], options: dict) -> float:
    """The objective (P&L minus fees) of a sequence of actions, stepped through the env."""
    env.reset(options=options)
    total = 0.0
    for a in actions:
        _, _, _, _, info = env.step(a)
        total += info["reward_components"]["pnl"] + info["reward_components"]["fees"]
    return total


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_the_plan_is_the_best_of_every_action_sequence_stepped_through_the_env(fidelity: str) -> None:
    env = gym.make(ENV, preset="test", fidelity=fidelity)
    n = env.unwrapped.n_steps
    episodes = protocol_episodes({"preset": "test"})
    for episode in (episodes[0], episodes[len(episodes) // 2], episodes[-1]):
        best = max(_play(env, seq, episode["options"]) for seq in itertools.product(range(3), repeat=n))
        policy = hindsight(env)
        obs, _ = env.reset(options=episode["options"])
        policy.reset(None)
        total, done = 0.0, False
        while not done:
            obs, _, terminated, truncated, info = env.step(policy(obs))
            total += info["reward_components"]["pnl"] + info["reward_components"]["fees"]
            done = terminated or truncated
        assert total == pytest.approx(best, rel=1e-12, abs=1e-9)
        assert policy.planned_objectives[-1] == pytest.approx(total, rel=1e-12, abs=1e-9)


def _objective(seq: tuple[int, ...], prices: np.ndarray, fee: float, close_new: bool) -> float:
    """P&L minus fees of a position sequence, written out from the env's docstring."""
    total, prev, before_last = 0.0, 0, 0
    for k, pos in enumerate(seq):
        total += 100_000.0 * pos * (prices[k + 1] - prices[k]) - fee * abs(pos - prev)
        before_last, prev = prev, pos
    return total - fee * abs(seq[-1] if close_new else before_last)


def test_plan_day_against_brute_force_on_random_prices() -> None:
    rng = np.random.default_rng(3)
    for _ in range(50):
        n = int(rng.integers(1, 7))
        prices = 1.1 + np.cumsum(rng.normal(0, 1e-3, n + 1))
        fee, close_new = float(rng.uniform(0, 150)), bool(rng.integers(2))
        positions, value = plan_day(prices, 100_000.0, fee, close_new)
        best = max(_objective(s, prices, fee, close_new) for s in itertools.product((-1, 0, 1), repeat=n))
        assert value == pytest.approx(best, abs=1e-9)
        assert _objective(tuple(positions), prices, fee, close_new) == pytest.approx(value, abs=1e-9)


def test_plan_day_refuses_a_day_without_two_finite_prices() -> None:
    with pytest.raises(ValueError, match="at least 2 finite prices"):
        plan_day([1.1], 100_000.0, 1.0)
    with pytest.raises(ValueError, match="at least 2 finite prices"):
        plan_day([1.1, float("nan")], 100_000.0, 1.0)


def test_hindsight_is_registered_non_causal_and_outside_the_scale_and_claims() -> None:
    from gym4real.bench.upper_reference import check_protocol
    from gym4real.core.registry import non_causal

    assert non_causal(ENV) == ["hindsight"]
    info = gym4real.env_info(ENV)
    assert "hindsight" in info.baselines and info.non_causal == ("hindsight",)
    check_protocol(ENV)  # neither rule-based nor in a claim's family


def test_hindsight_beats_every_baseline_and_published_agent_on_every_test_episode() -> None:
    """Exact: on each test day, no causal policy's recorded objective is above the planned optimum."""
    result = gym4real.benchmark(ENV, ["hindsight", "buy_and_hold", "sell_and_hold", "flat", "random"], "test")
    upper = np.asarray(result.objective_values("hindsight"))
    assert result.planned["hindsight"] == pytest.approx(upper.tolist(), abs=1e-6)
    for name in ("buy_and_hold", "sell_and_hold", "flat", "random"):
        assert np.all(upper >= np.asarray(result.objective_values(name)) - 1e-6), name
    published = pd.read_csv(PAPER)
    assert len(upper) == published["episode"].nunique()
    for policy, rows in published.groupby("policy"):
        matrix = rows.pivot_table(index=rows["seed"].fillna(-1), columns="episode", values="objective").to_numpy()
        assert np.all(upper[None, :] >= matrix - 1e-6), policy
