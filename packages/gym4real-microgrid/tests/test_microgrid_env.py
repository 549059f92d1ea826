from __future__ import annotations

import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gym4real
from gym4real.core.errors import ConfigError, DataFileError
from gym4real.core.testing import check_contract
from gym4real.microgrid import MicrogridEnv

ENV_ID = "gym4real/microgrid-v0"
DATA = Path(os.environ["GYM4REAL_DATA_DIR"]) / "microgrid"
# The spec's reference value: the default initial observation of profile 370 on the test data.
INITIAL_370 = [278.39, 0.2, 635, 0, 1.3327e-4, 4.627e-5, 7.17e-4, 1.0, 0.2588, 0.9659]


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_contract(fidelity: str) -> None:
    check_contract(ENV_ID, steps=100, seeded=fidelity == "corrected", fidelity=fidelity)


def test_contract_of_the_test_preset_with_soh_and_a_4h_decision() -> None:
    check_contract(ENV_ID, steps=30, preset="test", observe_soh=True, decision_interval=4)


def test_spaces() -> None:
    env = MicrogridEnv()
    assert env.action_space == gym.spaces.Box(0.0, 1.0, (1,), np.float32)
    assert env.observation_space.shape == (10,)
    assert env.feature_names[:3] == ("temperature", "soc", "demand")
    assert list(env.observation_space.low[:2]) == [250.0, 0.0]
    with_soh = MicrogridEnv(observe_soh=True)
    assert with_soh.observation_space.shape == (11,) and with_soh.feature_names[3] == "soh"
    obs, _ = with_soh.reset(seed=0)
    assert obs[3] == 1.0


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_initial_observation_matches_the_reference(fidelity: str) -> None:
    env = MicrogridEnv(fidelity=fidelity)
    obs, info = env.reset(options={"eval_profile": "370"})
    assert info["profile"] == "370"
    np.testing.assert_allclose(obs, INITIAL_370, rtol=2e-3, atol=1e-6)


def test_observation_timing() -> None:
    """Demand and PV of the hour just elapsed, prices of the upcoming hour (the one the action trades)."""
    pv = pd.read_csv(DATA / "generation" / "pv_ninja_2019-2020_3kW_test.csv")["PV"]
    market = pd.read_csv(DATA / "market" / "gme_2019-2020_test.csv")
    demand = pd.read_csv(DATA / "demand" / "profiles_test.csv")["371"]
    env = MicrogridEnv(preset="test")
    env.reset(options={"profile": "371"})
    for _ in range(11):
        obs, *_ = env.step(np.array([0.0], np.float32))
    assert obs[2] == np.float32(demand[11]) and obs[3] == np.float32(pv[11])
    assert obs[4] == np.float32(market["ask"][12]) and obs[5] == np.float32(market["bid"][12])


def test_only_market_trading_equals_the_data() -> None:
    """a = 0 trades the whole net power of every hour at that hour's price (hand-computed from the CSVs)."""
    pv = pd.read_csv(DATA / "generation" / "pv_ninja_2019-2020_3kW_test.csv")["PV"].to_numpy()
    market = pd.read_csv(DATA / "market" / "gme_2019-2020_test.csv")
    demand = pd.read_csv(DATA / "demand" / "profiles_test.csv")["380"].to_numpy()
    rows = np.arange(1, 301)
    net = pv[rows] - demand[rows]
    expected = np.where(net >= 0, net * market["bid"].to_numpy()[rows], net * market["ask"].to_numpy()[rows]).sum()
    env = MicrogridEnv(preset="test", max_steps=300)
    env.reset(options={"profile": "380"})
    total, done = 0.0, False
    while not done:
        _, _, terminated, truncated, info = env.step(np.array([0.0], np.float32))
        total += info["pure_components"]["trading"]
        assert info["energy"]["to_battery"] == info["energy"]["from_battery"] == 0.0
        done = terminated or truncated
    assert total == pytest.approx(expected, rel=1e-12)


actions = st.lists(st.floats(0.0, 1.0), min_size=1, max_size=150)


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
@settings(max_examples=15, deadline=None)
@given(actions=actions, start=st.integers(1, 8000))
def test_energy_balance_and_soc_window(fidelity: str, actions: list[float], start: int) -> None:
    env = MicrogridEnv(preset="test", fidelity=fidelity)
    env.reset(seed=start, options={"start": start})
    bat = env.battery
    for a in actions:
        soc0, cap0 = bat.soc, bat.capacity
        _, _, terminated, truncated, info = env.step(np.array([a], np.float32))
        e = info["energy"]
        # demand = PV + bought + from battery and surplus = sold + to battery, each hour
        supply = e["pv"] + e["bought"] + e["from_battery"]
        use = e["demand"] + e["sold"] + e["to_battery"]
        assert supply == pytest.approx(use, rel=1e-12, abs=1e-9)
        assert 0.2 - 1e-9 <= bat.soc <= 1.0 + 1e-9
        assert 0.2 - 1e-6 <= info["soc"] <= 1.0
        battery_wh = e["to_battery"] - e["from_battery"]
        if fidelity == "corrected":  # the battery took exactly the energy not traded
            assert bat.voltage * bat.current == pytest.approx(battery_wh, rel=1e-9, abs=1e-6)
            assert (bat.soc - soc0) * cap0 == pytest.approx(bat.current, rel=1e-9, abs=1e-9)
        if terminated or truncated:
            break


@settings(max_examples=15, deadline=None)
@given(actions=actions)
def test_soh_never_increases_in_the_default_mode(actions: list[float]) -> None:
    env = MicrogridEnv()
    env.reset(seed=len(actions))
    last = 1.0
    for a in actions * 3:
        _, _, _, _, info = env.step(np.array([a], np.float32))
        assert info["soh"] <= last
        assert info["pure_components"]["degradation"] <= 0.0
        last = info["soh"]


def test_reward_terms() -> None:
    env = MicrogridEnv()  # normalised, weights 1 / 1 / 0.1
    w = env.world
    env.reset(seed=1, options={"profile": "375"})
    for _ in range(40):
        _, reward, _, _, info = env.step(np.array([1.0], np.float32))
        pure, comps = info["pure_components"], info["reward_components"]
        assert comps["trading"] == pytest.approx(pure["trading"] / w.trading_norm)
        assert comps["degradation"] == pytest.approx(pure["degradation"])
        assert comps["clipping"] == pytest.approx(0.1 * pure["clipping"] / w.clipping_norm)
        assert reward == pytest.approx(sum(comps.values()))
    assert w.trading_norm == pytest.approx(0.66332, rel=1e-4)  # the spec's values on the test data
    assert w.clipping_norm == pytest.approx(3395.0)


def test_degradation_cost_is_the_soh_drop_valued_at_the_replacement_cost() -> None:
    env = MicrogridEnv(preset="test")
    env.reset(options={"profile": "390"})
    soh = 1.0
    for _ in range(24):
        _, _, _, _, info = env.step(np.array([0.7], np.float32))
        drop = soh - info["soh"]
        assert info["pure_components"]["degradation"] == pytest.approx(-drop * 3000.0 / 0.4, rel=1e-9, abs=1e-15)
        soh = info["soh"]


def test_cost_is_the_soc_window_violation() -> None:
    env = MicrogridEnv(preset="test")
    env.reset(options={"profile": "370"})  # night, SoC at its minimum 0.2
    _, _, _, _, info = env.step(np.array([1.0], np.float32))  # asks the empty battery for the demand
    assert info["cost"] > 0.0 and info["pure_components"]["clipping"] < 0.0
    env.reset(options={"profile": "370"})
    _, _, _, _, info = env.step(np.array([0.0], np.float32))
    assert info["cost"] == 0.0 and info["pure_components"]["clipping"] == 0.0


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_truncation_at_the_end_of_data(fidelity: str) -> None:
    env = MicrogridEnv(preset="test", fidelity=fidelity)
    if fidelity == "corrected":
        env.reset(options={"start": 8755})
        steps = 8760 - 8755
    else:
        env.reset()
        env._iterations = 8750  # the reference counts 8759 steps from its start
        steps = 9
    for n in range(1, steps + 1):
        _, _, terminated, truncated, _ = env.step(np.array([0.5], np.float32))
        assert not terminated
        assert truncated == (n == steps)


def test_episode_length_of_a_test_year() -> None:
    env = MicrogridEnv(preset="test")
    env.reset(options={"profile": "377"})
    assert env._limit == 8759


def test_termination_at_end_of_life() -> None:
    env = MicrogridEnv(battery={"eol_soh": 0.99999})
    env.reset(seed=0)
    steps = 0
    for steps in range(1, 200):  # noqa: B007
        _, _, terminated, truncated, info = env.step(np.array([1.0], np.float32))
        if terminated:
            break
    assert terminated and not truncated and info["soh"] <= 0.99999 and steps > 1


def test_decision_interval_holds_the_action() -> None:
    hourly = MicrogridEnv(preset="test", max_steps=48)
    four = MicrogridEnv(preset="test", max_steps=48, decision_interval=4)
    hourly.reset(options={"profile": "372"})
    four.reset(options={"profile": "372"})
    for k in range(12):
        a = np.array([(k % 3) / 2], np.float32)
        total = 0.0
        for _ in range(4):
            obs_h, r, *_ = hourly.step(a)
            total += r
        obs_4, r4, _, truncated, _ = four.step(a)
        assert r4 == pytest.approx(total, rel=1e-12, abs=1e-15)
        np.testing.assert_array_equal(obs_4, obs_h)
    assert truncated


def test_test_preset_iterates_the_28_profiles() -> None:
    env = MicrogridEnv(preset="test")
    assert env.profiles == tuple(str(p) for p in range(370, 398))
    seen = [env.reset()[1]["profile"] for _ in range(30)]
    assert seen[:28] == list(env.profiles) and seen[28:] == ["370", "371"]
    assert env.reset(seed=3)[1]["profile"] == "373"
    assert env.reset()[1]["profile"] == "374"


def test_default_preset_draws_the_profile_from_the_seed() -> None:
    env = MicrogridEnv()
    draws = {env.reset(seed=s)[1]["profile"] for s in range(30)}
    assert len(draws) > 5
    assert env.reset(seed=4)[1]["profile"] == MicrogridEnv().reset(seed=4)[1]["profile"]


def test_upstream_draws_from_its_construction_seed() -> None:
    a, b = MicrogridEnv(fidelity="upstream"), MicrogridEnv(fidelity="upstream")
    legacy = np.random.RandomState(42)
    for seed in (1, 2, 3):
        expected = str(legacy.choice(list(a.profiles)))
        assert a.reset(seed=seed)[1]["profile"] == expected == b.reset()[1]["profile"]


def test_random_start_and_battery_init_follow_the_seed() -> None:
    env = MicrogridEnv(random_start=True, random_battery_init=True)
    first = env.reset(seed=9)
    again = env.reset(seed=9)
    np.testing.assert_array_equal(first[0], again[0])
    assert first[1]["start"] == again[1]["start"] != 1
    assert 0.2 <= first[1]["soc"] <= 1.0 and 0.6 <= first[1]["soh"] <= 1.0


@pytest.mark.parametrize("action", [np.array([np.nan], np.float32), np.array([1.5], np.float32), [0.2, 0.3]])
def test_bad_actions_raise(action: object) -> None:
    env = MicrogridEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(action)  # type: ignore[arg-type]


def test_config_errors() -> None:
    with pytest.raises(ConfigError, match="decision_interval"):
        MicrogridEnv(decision_interval=0)
    with pytest.raises(ConfigError, match=r"unknown field `reward\.weight`"):
        MicrogridEnv(reward={"weight": 2})
    with pytest.raises(DataFileError, match=r"not columns"):
        MicrogridEnv(profiles=["999"])


def test_train_split_runs_with_a_user_demand_file(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    frame = pd.DataFrame(rng.uniform(0, 2000, size=(8760, 3)), columns=["0", "1", "2"])
    frame["delta_time"] = np.arange(8760) * 3600.0
    path = tmp_path / "profiles.csv"
    frame.to_csv(path, index=False)
    env = MicrogridEnv(preset="train", data={"demand": str(path)})
    obs, info = env.reset(seed=0)
    assert env._limit == 35063 and info["profile"] in {"0", "1", "2"}
    env.step(np.array([0.5], np.float32))
    env._row = 8760 + 5  # the 8760-hour profile repeats over the 4 years
    obs, *_ = env.step(np.array([0.5], np.float32))
    assert obs[2] == np.float32(frame[info["profile"]][5])


def test_malformed_data_file(tmp_path: Path) -> None:
    bad = tmp_path / "pv.csv"
    bad.write_text("timestamp,delta_time\n2019-01-01,0\n2019-01-01 01:00,3600\n")
    with pytest.raises(DataFileError, match=r"pv\.csv.*lacks column\(s\) \['PV'\]"):
        MicrogridEnv(data={"generation": str(bad)})


@pytest.mark.parametrize(("fidelity", "row"), [("corrected", 8759), ("upstream", 0)])
def test_last_step_trades_the_last_hour_or_wraps_like_the_reference(fidelity: str, row: int) -> None:
    pv = pd.read_csv(DATA / "generation" / "pv_ninja_2019-2020_3kW_test.csv")["PV"].to_numpy()
    market = pd.read_csv(DATA / "market" / "gme_2019-2020_test.csv")
    demand = pd.read_csv(DATA / "demand" / "profiles_test.csv")["370"].to_numpy()
    env = MicrogridEnv(preset="test", fidelity=fidelity)
    env.reset(options={"profile": "370"})
    env._row, env._iterations = 8759, 8758  # the last hour of 2019
    _, _, _, truncated, info = env.step(np.array([0.0], np.float32))
    net = pv[row] - demand[8759]  # demand wraps at 8760 rows in both modes
    price = market["bid"][row] if net >= 0 else market["ask"][row]
    assert truncated and info["pure_components"]["trading"] == pytest.approx(net * price, rel=1e-12)


def test_missing_series_are_the_constant_dummies() -> None:
    """No generation, market or temperature file: the reference's constants (10 W, 0.21 / 0.14 EUR/kWh, 298.15 K)."""
    env = MicrogridEnv(preset="test", data={"generation": None, "market": None, "temp_amb": None})
    demand = pd.read_csv(gym4real.core.datasets.resolve("microgrid/demand/test"))
    obs, info = env.reset(options={"profile": "370"})
    names = env.feature_names
    assert obs[names.index("temperature")] == np.float32(298.15)  # the battery starts at the ambient temperature
    for _ in range(24):
        obs, _, _, _, info = env.step(np.array([0.3], dtype=np.float32))
        assert (obs[names.index("generation")], obs[names.index("ask")], obs[names.index("bid")]) == (
            np.float32(10.0),
            np.float32(0.00021),
            np.float32(0.00014),
        )
        energy = info["energy"]
        assert energy["pv"] == 10.0
        assert info["pure_components"]["trading"] == pytest.approx(
            0.00014 * energy["sold"] - 0.00021 * energy["bought"], rel=1e-12
        )
    # the episode spans the demand file's hours: from its last-but-one row, one step
    env.reset(options={"profile": "370", "start": len(demand) - 1})
    *_, truncated, _ = env.step(np.array([0.3], dtype=np.float32))
    assert truncated


def test_upstream_needs_generation_data() -> None:
    with pytest.raises(ConfigError, match="defect 11"):
        MicrogridEnv(fidelity="upstream", data={"generation": None})
    env = MicrogridEnv(fidelity="upstream", data={"market": None, "temp_amb": None})  # these run in the reference
    obs, _ = env.reset()
    assert obs[env.feature_names.index("ask")] == np.float32(0.00021)
