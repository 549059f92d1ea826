from __future__ import annotations

import datetime as dt
import os
from functools import cache
from pathlib import Path

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import gym4real  # noqa: F401  (registers the ids)
from gym4real.core.errors import ConfigError
from gym4real.core.testing import check_contract
from gym4real.trading import TradingConfig, TradingEnv
from gym4real.trading.features import feature_names

ENV_ID = "gym4real/trading-v0"
DATA = Path(os.environ["GYM4REAL_DATA_DIR"]) / "trading"
CAPITAL, FEE = 100_000.0, 1.0


@cache
def env_of(fidelity: str, preset: str = "default") -> TradingEnv:
    return TradingEnv(preset=preset, fidelity=fidelity)


@cache
def raw_closes(day: str, first: int = 8, last: int = 16) -> np.ndarray:
    """The day's hourly closes first..last-1 EST read straight from the Dukascopy file (UTC -> UTC-5)."""
    df = pd.read_csv(DATA / "eurusd_1h_ask_2017.csv")
    t = pd.to_datetime(df["Time"], format="%d.%m.%Y %H:%M:%S.%f") - pd.Timedelta(hours=5)
    sel = (t.dt.strftime("%Y-%m-%d") == day) & (t.dt.hour >= first) & (t.dt.hour < last)
    closes = df.loc[sel, "Close"].to_numpy(dtype=float)
    assert len(closes) == last - first, (day, len(closes))
    return closes


def raw_session_closes(day: str) -> np.ndarray:
    return raw_closes(day)


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_contract(fidelity: str) -> None:
    check_contract(ENV_ID, steps=30, fidelity=fidelity)


def test_contract_of_the_sequential_test_preset() -> None:
    check_contract(ENV_ID, steps=30, preset="test")


def test_spaces_and_layout() -> None:
    env = env_of("corrected")
    assert env.action_space == gym.spaces.Discrete(3)
    assert env.observation_space.shape == (24 + 2 + 1,)
    assert env.observation_space.dtype == np.float32
    assert env_of("upstream").observation_space.dtype == np.float64
    # the paper's layout: 60 changes, time sin/cos, position = 63 (no data needed to know it)
    paper = TradingConfig.build(preset="paper_train")
    names = feature_names(paper)
    assert len(names) == 63 and names[-3:] == ["time_sin", "time_cos", "position"]
    cal = TradingConfig.build(preset="paper_train", use_month=True, use_day=True, use_day_of_week=True)
    assert len(feature_names(cal)) == 60 + 3 * 2 + 2 + 1
    assert len(feature_names(cal.model_copy(update={"fidelity": "upstream"}))) == 60 + 3 + 2 + 1


def test_observation_matches_position_and_time() -> None:
    env = env_of("corrected")
    obs, _ = env.reset(options={"day": "2017-03-01"})
    assert obs[-1] == 1  # flat at the open
    np.testing.assert_allclose(obs[-3:-1], [0.0, 1.0], atol=1e-7)  # sin, cos of 0
    for a in (2, 0, 1, 2):
        obs, *_ = env.step(a)
        assert obs[-1] == a
    with pytest.raises(ValueError):
        obs[0] = 1.0  # returned rows are read-only views


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_pnl_accounting_equals_independent_recomputation(fidelity: str, data: st.DataObject) -> None:
    env = env_of(fidelity)
    index = data.draw(st.integers(0, len(env.days) - 1), label="day")
    actions = data.draw(st.lists(st.integers(0, 2), min_size=env.n_steps, max_size=env.n_steps), label="actions")
    day = env.days[index].isoformat()
    env.reset(options={"day": day})
    rewards, comps = [], []
    for i, a in enumerate(actions):
        _, reward, terminated, truncated, info = env.step(a)
        rewards.append(reward)
        comps.append(info["reward_components"])
        assert truncated == (i == len(actions) - 1)
        assert terminated == (truncated and fidelity == "upstream")
    # independent recomputation from the raw price file
    prices = raw_session_closes(day)
    pos = np.array(actions) - 1
    held = np.r_[0, pos]
    pnl = CAPITAL * np.sum(pos * np.diff(prices[: len(pos) + 1]))
    fees = FEE * np.sum(np.abs(np.diff(held)))
    fees += FEE * abs(pos[-1] if fidelity == "corrected" else held[-2])
    assert np.isclose(sum(rewards), pnl - fees, rtol=0, atol=1e-6)
    assert np.isclose(info["cum_pnl"], pnl, atol=1e-6) and np.isclose(info["cum_fees"], fees, atol=1e-9)
    assert np.isclose(sum(c["pnl"] + c["fees"] for c in comps), sum(rewards), atol=1e-9)


def test_episode_lengths_and_forced_close_every_day() -> None:
    for fidelity, steps in (("corrected", 7), ("upstream", 6)):
        env = env_of(fidelity)
        assert env.n_steps == steps
        for day in env.days:
            totals = []
            for action in (2, 0):  # buy and hold, sell and hold
                obs, _ = env.reset(options={"day": day})
                n, done, total = 0, False, 0.0
                while not done:
                    obs, reward, terminated, truncated, info = env.step(action)
                    total += reward
                    n += 1
                    done = terminated or truncated
                assert n == steps and truncated
                assert obs[-1] == 1  # flat after the forced close
                assert info["position"] == action - 1  # held over the last interval
                assert info["cum_fees"] == 2 * FEE  # open and forced close
                totals.append(total)
            # P&L of B&H and S&H cancel: each pays one opening and one closing fee
            assert np.isclose(sum(totals), -4 * FEE, atol=1e-6)
        with pytest.raises(RuntimeError, match="reset"):
            env.step(1)


@pytest.mark.parametrize(
    ("actions", "corrected", "upstream"),
    [
        ([1] * 6 + [2], 2.0, 1.0),  # opened at the last step: upstream never charges its close
        ([2] * 6 + [1], 2.0, 3.0),  # closed at the last step: upstream charges the close twice
        ([2] * 7, 2.0, 2.0),
        ([1] * 7, 0.0, 0.0),
        ([0, 2] * 3 + [0], 1 + 2 * 6 + 1.0, None),
    ],
)
def test_close_fee_defect_is_switchable(actions: list[int], corrected: float, upstream: float | None) -> None:
    for close_new, expected in ((True, corrected), (False, upstream)):
        if expected is None:
            continue
        env = TradingEnv(fixes={"full_session": True, "close_fee_on_new_position": close_new})
        env.reset(options={"day": 0})
        for a in actions:
            *_, info = env.step(a)
        assert info["cum_fees"] == expected


@pytest.mark.parametrize("bad", [3, -1, 1.5, float("nan"), "1", None, np.array([1, 2]), True, np.float64(1.0)])
def test_bad_actions_raise(bad: object) -> None:
    env = env_of("corrected")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="not in the action space"):
        env.step(bad)


def test_numpy_integer_actions_are_accepted() -> None:
    env = env_of("corrected")
    env.reset(seed=0)
    for a in (np.int64(2), np.array(0), np.array([1]), np.uint8(2), np.int32(0)):
        env.step(a)


def test_day_selection() -> None:
    env = env_of("corrected")
    _obs, info = env.reset(options={"day": "2017-03-01"})
    assert info["day"] == "2017-03-01" and info["timestamp"] == np.datetime64("2017-03-01T08:00")
    assert env.reset(options={"day": dt.date(2017, 3, 1)})[1]["day"] == "2017-03-01"
    assert env.reset(options={"day": 0})[1]["day"] == env.days[0].isoformat() == "2017-01-02"
    with pytest.raises(ValueError, match="not a trading day"):
        env.reset(options={"day": "2017-03-04"})  # a Saturday
    test = env_of("corrected", "test")
    with pytest.raises(ValueError, match="dropped: no quotes"):
        test.reset(options={"day": "2017-12-25"})
    with pytest.raises(ValueError, match="dropped: gap"):
        test.reset(options={"day": "2018-02-07"})  # the file ends at 10:00 EST


def test_seeded_random_days_and_sequential_order() -> None:
    env = env_of("corrected")
    days = [env.reset(seed=s)[1]["day"] for s in range(30)]
    assert days == [env.reset(seed=s)[1]["day"] for s in range(30)]
    assert len(set(days)) > 15
    state = np.random.get_state()[1].copy()
    env.reset(seed=1)
    env.step(2)
    np.testing.assert_array_equal(np.random.get_state()[1], state)  # the global RNG is untouched
    seq = env_of("corrected", "validation")
    assert seq.config.sequential
    assert seq.reset(seed=3)[1]["day"] == seq.days[3].isoformat()
    assert seq.reset()[1]["day"] == seq.days[4].isoformat()
    assert seq.reset(seed=len(seq.days) + 1)[1]["day"] == seq.days[1].isoformat()


def test_normalisation_is_fitted_on_the_train_split_only() -> None:
    train, test = env_of("corrected"), env_of("corrected", "test")
    s_train, s_test = train.get_scaler(), test.get_scaler()
    assert s_train is not None and s_test is not None
    np.testing.assert_array_equal(s_train.data_min_, s_test.data_min_)
    np.testing.assert_array_equal(s_train.data_max_, s_test.data_max_)
    # independent check of the fitted range: hourly changes of the train days' sessions
    closes = np.stack([raw_session_closes(d.isoformat()) for d in train.days[:5]])
    inner = closes[:, 1:] / closes[:, :-1] - 1  # changes inside a session (lag 0 from 09:00 on)
    assert s_train.data_min_[0] <= inner.min() and inner.max() <= s_train.data_max_[0]
    scaled = train._features[..., :24]
    assert scaled.min() >= -1e-6 and scaled.max() <= 1 + 1e-6
    assert np.isclose(scaled.min(), 0, atol=1e-6) and np.isclose(scaled.max(), 1, atol=1e-6)
    raw = TradingEnv(normalize=False)
    assert raw.get_scaler() is None
    raw.reset(options={"day": "2017-03-01"})
    obs, *_ = raw.step(1)
    p7, p8, p9 = raw_closes("2017-03-01", 7, 10)
    assert np.isclose(obs[0], p9 / p8 - 1, rtol=1e-5)  # delta_mid_0 at 09:00
    assert np.isclose(obs[1], p8 / p7 - 1, rtol=1e-5)  # the 08:00 change uses the pre-session 07:00 bar


def test_config_errors_name_the_field() -> None:
    with pytest.raises(ConfigError, match="persistence"):
        TradingConfig.build(persistence=30, bar_minutes=60)
    with pytest.raises(ConfigError, match="trading_close"):
        TradingConfig.build(trading_open=10, trading_close=9)
    with pytest.raises(ConfigError, match="unknown field"):
        TradingConfig.build(persistance=5)
    with pytest.raises(ConfigError, match="years"):
        TradingConfig.build(splits={"test": {"years": [2022], "start": "2022-01-01", "end": "2022-02-01"}})


def test_render_modes() -> None:
    env = TradingEnv(render_mode="ansi")
    env.reset(options={"day": "2017-03-01"})
    env.step(2)
    env.step(0)
    line = env.render()
    assert isinstance(line, str) and line.startswith("2017-03-01 10:00") and "[LS" in line
    picture = TradingEnv(render_mode="rgb_array")
    picture.reset(seed=0)
    picture.step(2)
    img = picture.render()
    assert isinstance(img, np.ndarray) and img.shape == (120, 240, 3) and img.dtype == np.uint8
    assert (img[..., 1] > img[..., 0] + 50).any()  # the long stretch is drawn green
    with pytest.raises(ValueError, match="render_mode"):
        TradingEnv(render_mode="human")
