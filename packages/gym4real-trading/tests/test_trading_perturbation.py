"""Exogenous perturbation of TradingEnv: price shocks around the day's first price and scaled fees."""

from __future__ import annotations

import math
import pickle
from collections.abc import Sequence
from typing import Any

import numpy as np
import pytest

from gym4real.trading import TradingEnv
from gym4real.trading.vector import TradingVectorEnv

ACTIONS = [2, 2, 0, 1, 0, 2, 2]  # long, hold, reverse, flat, short, reverse, hold (7 decisions)
RAW: dict[str, Any] = {"normalize": False, "fixes": {"float32_observations": False}}  # changes as float64


def episode(env: TradingEnv, actions: Sequence[int], day: int = 5) -> dict[str, list[Any]]:
    """Observations, rewards, reward components and prices of one day under fixed actions."""
    obs, info = env.reset(seed=3, options={"day": day})
    out: dict[str, list[Any]] = {"obs": [obs], "reward": [], "pnl": [], "fees": [], "price": [info["mid_price"]]}
    for a in actions[: env.n_steps]:
        obs, reward, _, _, info = env.step(a)
        out["obs"].append(obs)
        out["reward"].append(reward)
        out["pnl"].append(info["reward_components"]["pnl"])
        out["fees"].append(info["reward_components"]["fees"])
        out["price"].append(info["mid_price"])
    return out


def assert_same(x: dict[str, list[Any]], y: dict[str, list[Any]]) -> None:
    for key in x:
        if key == "obs":
            for a, b in zip(x[key], y[key], strict=True):
                np.testing.assert_array_equal(a, b)
        else:
            assert x[key] == y[key], key


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_unit_scales_and_empty_perturbation_restore_the_nominal_trajectory(fidelity: str) -> None:
    nominal = episode(TradingEnv(fidelity=fidelity), ACTIONS)
    env = TradingEnv(fidelity=fidelity)
    env.perturb({"price_shock": 1.0, "fees": 1.0})
    assert_same(episode(env, ACTIONS), nominal)
    env.perturb({"price_shock": 1.4, "fees": 0.3})
    episode(env, ACTIONS)
    env.perturb({})
    assert_same(episode(env, ACTIONS), nominal)


@pytest.mark.parametrize("scale", [0.25, 3.0])
def test_fees_scale_multiplies_the_fee_component_only(scale: float) -> None:
    env = TradingEnv()
    nominal = episode(env, ACTIONS)
    env.perturb({"fees": scale})
    scaled = episode(env, ACTIONS)
    assert scaled["pnl"] == nominal["pnl"] and scaled["price"] == nominal["price"]
    assert any(nominal["fees"])
    assert scaled["fees"] == pytest.approx([scale * f for f in nominal["fees"]], rel=1e-12)
    assert scaled["reward"] == pytest.approx([p + f for p, f in zip(scaled["pnl"], scaled["fees"], strict=True)])


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
@pytest.mark.parametrize("shock", [0.4, 1.7])
def test_price_shock_scales_the_pnl_of_every_holding_exactly(fidelity: str, shock: float) -> None:
    nominal_env, env = TradingEnv(fidelity=fidelity), TradingEnv(fidelity=fidelity)
    env.perturb({"price_shock": shock})
    for day in range(0, len(env.days), 7):
        for hold in (0, 2):  # short or long all day
            nominal = episode(nominal_env, [hold] * env.n_steps, day)
            shocked = episode(env, [hold] * env.n_steps, day)
            p0 = nominal["price"][0]
            assert shocked["price"][0] == p0
            for p, q in zip(nominal["price"], shocked["price"], strict=True):
                assert q - p0 == pytest.approx(shock * (p - p0), rel=1e-9, abs=1e-15)
            # P&L of each holding interval and of the day: s times the nominal one
            assert shocked["pnl"] == pytest.approx([shock * x for x in nominal["pnl"]], rel=1e-9, abs=1e-9)
            assert sum(shocked["pnl"]) == pytest.approx(shock * sum(nominal["pnl"]), rel=1e-9, abs=1e-9)
            assert shocked["fees"] == nominal["fees"]


@pytest.mark.parametrize("offset", [60, 120])
def test_observed_changes_are_those_of_the_shocked_prices(offset: int) -> None:
    """Changes within the session follow the shocked prices; the history before the open is kept."""
    shock = 1.6
    nominal = episode(TradingEnv(offset=offset, **RAW), [1] * 7, day=11)
    env = TradingEnv(offset=offset, **RAW)
    env.perturb({"price_shock": shock})
    shocked = episode(env, [1] * 7, day=11)
    nominal_prices, prices = nominal["price"], shocked["price"]  # every session bar (hourly decisions)
    off, n = offset // 60, env.config.number_of_deltas
    seen = {"inside": 0, "before": 0, "across": 0}
    for t, (obs_nominal, obs) in enumerate(zip(nominal["obs"], shocked["obs"], strict=True)):
        for j in range(n):
            a = t - j * off
            b = a - off
            if b >= 0:
                assert obs[j] == pytest.approx(prices[a] / prices[b] - 1.0, rel=1e-12)
                seen["inside"] += 1
            elif a <= 0:  # before the open, or from the opening price p0, unchanged by the shock
                assert obs[j] == obs_nominal[j]
                seen["before"] += 1
            else:  # p(a) shocked, p(b) the history: (1 + d') / (1 + d) = p'(a) / p(a)
                assert (1 + obs[j]) / (1 + obs_nominal[j]) == pytest.approx(prices[a] / nominal_prices[a], rel=1e-12)
                seen["across"] += 1
        np.testing.assert_array_equal(obs[n:], obs_nominal[n:])  # time of day and position
    assert seen["inside"] and seen["before"] and (seen["across"] or off == 1)


def test_normalised_observation_scales_the_shocked_changes() -> None:
    raw, scaled = TradingEnv(**RAW), TradingEnv()
    for env in (raw, scaled):
        env.perturb({"price_shock": 2.0})
    obs_raw, obs_scaled = episode(raw, ACTIONS)["obs"], episode(scaled, ACTIONS)["obs"]
    scaler, n = scaled.get_scaler(), scaled.config.number_of_deltas
    assert scaler is not None
    for x, y in zip(obs_raw, obs_scaled, strict=True):
        np.testing.assert_array_equal(y[:n], scaler.transform(x[:n]).astype(np.float32))


def test_perturbation_never_compounds_and_persists_across_resets() -> None:
    once = TradingEnv()
    once.perturb({"price_shock": 1.3, "fees": 2.0})
    first = episode(once, ACTIONS)
    assert_same(episode(once, ACTIONS), first)  # persists until the next `perturb`
    twice = TradingEnv()
    for _ in range(2):
        twice.perturb({"price_shock": 1.3, "fees": 2.0})
        episode(twice, ACTIONS[:2])
    assert_same(episode(twice, ACTIONS), first)


def test_perturbed_env_pickles_with_its_scales() -> None:
    env = TradingEnv()
    env.perturb({"price_shock": 0.7, "fees": 1.5})
    assert_same(episode(pickle.loads(pickle.dumps(env)), ACTIONS), episode(env, ACTIONS))


@pytest.mark.parametrize(
    ("scales", "match"),
    [
        ({"fee": 1.1}, r"unknown perturbation parameters \['fee'\].*'price_shock', 'fees'"),
        ({"fees": 0.0}, "`fees` must be a finite number > 0, not 0.0"),
        ({"price_shock": -0.5}, "`price_shock` must be a finite number > 0"),
        ({"price_shock": math.nan}, "`price_shock` must be a finite number > 0, not nan"),
        ({"fees": math.inf}, "`fees` must be a finite number > 0"),
        ({"fees": "2"}, "`fees` must be a finite number > 0"),
        ({"price_shock": False}, "`price_shock` must be a finite number > 0"),
    ],
)
def test_bad_perturbations_raise(scales: dict[str, Any], match: str) -> None:
    env = TradingEnv()
    env.perturb({"fees": 2.0})
    with pytest.raises(ValueError, match=match):
        env.perturb(scales)
    assert env._scales == {"price_shock": 1.0, "fees": 2.0}  # a rejected call changes nothing


def test_a_shock_that_makes_a_price_non_positive_is_refused_at_reset() -> None:
    env = TradingEnv()
    env.perturb({"price_shock": 1e6})  # intraday moves of about 1e-3 times 1e6
    with pytest.raises(ValueError, match=r"`price_shock` 1e\+06 drives the price of .* <= 0"):
        for day in range(len(env.days)):
            env.reset(options={"day": day})


def test_vector_env_trades_the_nominal_market() -> None:
    """TradingVectorEnv has no ``perturb``; perturbing its inner single env does not change it."""
    vec = TradingVectorEnv(2)
    assert not hasattr(vec, "perturb") and not hasattr(vec, "perturbable")
    vec.single.perturb({"price_shock": 2.0, "fees": 3.0})
    singles = [TradingEnv(), TradingEnv()]
    vec.reset(seed=8)
    for i, e in enumerate(singles):
        e.reset(seed=8 + i)
    for a in ACTIONS:
        _, rewards, *_ = vec.step(np.full(2, a))
        np.testing.assert_allclose(rewards, [e.step(a)[1] for e in singles], rtol=0, atol=1e-9)
