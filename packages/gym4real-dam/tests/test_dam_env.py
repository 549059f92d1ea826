from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gym4real  # noqa: F401  (registers the ids)
from gym4real.core.errors import ConfigError
from gym4real.core.testing import check_contract
from gym4real.dam import DamEnv
from gym4real.dam.evaluation import TEST_YEARS

ENV_ID = "gym4real/dam-v0"
COMPONENTS = {"deficit", "overflow", "starving", "wasted_water", "clipping"}


@pytest.mark.parametrize(
    ("kwargs", "seeded"),
    [
        ({}, True),
        ({"preset": "test"}, True),
        ({"fidelity": "upstream"}, True),  # the reference's random.Random(seed) draw is repeatable
        ({"preset": "test", "fidelity": "upstream"}, False),  # the reference ignores the seed in cycle mode
    ],
)
def test_contract(kwargs: dict[str, object], seeded: bool) -> None:
    check_contract(ENV_ID, steps=400, seeded=seeded, **kwargs)


def test_spaces_and_initial_observation_match_the_spec() -> None:
    env = DamEnv()
    assert env.action_space.shape == (1,) and env.action_space.dtype == np.float32
    assert env.action_space.low[0] == 0.0 and env.action_space.high[0] == np.float32(491.61)
    assert env.observation_space.shape == (4,) and env.observation_space.dtype == np.float32
    assert env.observation_space.low.dtype == np.float32
    np.testing.assert_array_equal(env.observation_space.low, [-1.0, -1.0, -1.0, 0.0])
    np.testing.assert_array_equal(env.observation_space.high, [6.0, 1.0, 1.0, 1000.0])
    obs, info = env.reset(seed=0)
    np.testing.assert_array_equal(obs, np.array([0.35, 0.0, 1.0, 0.0], dtype=np.float32))
    assert info["storage"] == pytest.approx(1.24015e8)
    assert info["year"] in env.years and len(env.years) == 52


def test_observation_features_keep_the_reference_order() -> None:
    env = DamEnv(observations=["exponential_average_demand", "level"])
    obs, _ = env.reset(seed=0)
    assert obs.shape == (2,)
    obs, *_ = env.step(np.array([50.0]))
    assert obs[0] == np.float32(env.level) and obs[1] == np.float32(env.exponential_average_demand)


def test_episode_is_one_year_and_only_truncates() -> None:
    env = DamEnv(preset="test")
    env.reset(options={"year": 1950})
    for t in range(365):
        obs, reward, terminated, truncated, info = env.step(np.array([200.0], dtype=np.float32))
        assert not terminated
        assert truncated == (t == 364)
        assert set(info["reward_components"]) == COMPONENTS
        assert sum(info["reward_components"].values()) == pytest.approx(reward, abs=1e-9)
        assert info["day_of_year"] == t + 1
    # corrected: the last observation is the current level and day 1 of the next year
    assert obs[0] == np.float32(info["level"]) and obs[1] == 0.0 and obs[2] == 1.0
    assert info["recorded_level_rmse"] > 0
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.array([1.0], dtype=np.float32))


def test_upstream_final_observation_shows_the_initial_level() -> None:
    env = DamEnv(preset="test", fidelity="upstream")
    env.reset(options={"year": 1950})
    for _ in range(365):
        obs, *_ = env.step(np.array([200.0], dtype=np.float32))
    np.testing.assert_array_equal(obs[:3], np.array([0.35, 0.0, 1.0], dtype=np.float32))


def test_reward_terms_follow_the_appendix() -> None:
    env = DamEnv(preset="test")
    env.reset(options={"year": 1970})
    for t in range(365):
        a = float((t * 37) % 491)
        _, _reward, _, _, info = env.step(np.array([a], dtype=np.float32))
        u, w = info["unweighted_components"], info["reward_components"]
        q, d = info["release"], info["demand"]
        weight = 0.5 * (3 - np.cos(2 * np.pi * t / 365))
        assert -u["deficit"] == pytest.approx(max(d - max(q - 5.0, 0.0), 0.0) * weight)
        assert -u["wasted_water"] == pytest.approx(max(q - d, 0.0))
        assert -u["clipping"] == pytest.approx((float(np.float32(a)) - q) ** 2)
        assert u["overflow"] == -float(info["level"] > 1.24)
        assert u["starving"] == -float(info["level"] < -0.45)
        assert w["deficit"] == u["deficit"] and w["overflow"] == 1000 * u["overflow"]
        assert w["starving"] == 250 * u["starving"] and w["wasted_water"] == 0.2 * u["wasted_water"]
        assert w["clipping"] == 0.0005 * u["clipping"]
        assert info["cost"] == float(u["overflow"] < 0 or u["starving"] < 0)
        assert all(v <= 0 for v in w.values())


def test_exponential_average_demand_includes_todays_demand() -> None:
    env = DamEnv(preset="test")
    env.reset(options={"year": 1950})
    expected = 0.0
    for _ in range(10):
        _, _, _, _, info = env.step(np.array([100.0], dtype=np.float32))
        expected = 0.8 * expected + (1 - 0.8) * info["demand"]
        assert info["exponential_average_demand"] == expected


def test_test_preset_iterates_the_thirteen_test_years_in_order() -> None:
    env = DamEnv(preset="test")
    assert env.years == TEST_YEARS
    assert [env.reset()[1]["year"] for _ in range(14)] == [*TEST_YEARS, TEST_YEARS[0]]
    assert env.reset(options={"year": 2009})[1]["year"] == 2009
    assert env.reset()[1]["year"] == 2010  # the cycle continues from the chosen year
    assert env.reset(options={"rewind_profiles": True})[1]["year"] == 1950
    assert env.reset(seed=3)[1]["year"] == TEST_YEARS[3]  # corrected: a seeded reset picks year seed % 13
    with pytest.raises(ValueError, match="1951"):
        env.reset(options={"year": 1951})
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(options={"years": 1950})


def test_upstream_cycle_skips_the_first_year_without_rewind() -> None:
    env = DamEnv(preset="test", fidelity="upstream")  # the reference took 1950 at construction
    assert env.reset(seed=3)[1]["year"] == 1970
    assert env.reset(options={"rewind_profiles": True})[1]["year"] == 1950


def test_train_years_come_from_the_seed() -> None:
    env = DamEnv()
    years = [env.reset(seed=s)[1]["year"] for s in range(40)]
    assert years == [env.reset(seed=s)[1]["year"] for s in range(40)]
    assert len(set(years)) > 20 and set(years) <= set(env.years)
    assert not set(years) & set(TEST_YEARS)


def test_reset_from_another_level_checks_the_bounds() -> None:
    env = DamEnv(preset="test")
    obs, info = env.reset(options={"year": 1950, "init_level": 0.92})
    assert obs[0] == np.float32(0.92) and info["level"] == 0.92
    with pytest.raises(ValueError, match="level_bounds"):
        env.reset(options={"init_level": 7.5})


@pytest.mark.parametrize("action", [np.array([np.nan], dtype=np.float32), float("nan"), [np.nan]])
def test_nan_action_is_a_clear_error(action: object) -> None:
    env = DamEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="NaN"):
        env.step(action)


@pytest.mark.parametrize("action", [np.zeros(2, dtype=np.float32), "much", [[1.0, 2.0]], None])
def test_malformed_action_is_a_clear_error(action: object) -> None:
    env = DamEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(action)


def test_out_of_space_actions_are_clipped_with_the_clipping_penalty() -> None:
    env = DamEnv(preset="test")
    env.reset(options={"year": 1950})
    _, _, _, _, info = env.step(np.array([-50.0], dtype=np.float32))
    assert info["action"] == 0.0 and info["raw_action"] == -50.0
    assert info["release"] == 5.0  # raised to the minimum flow
    assert info["unweighted_components"]["clipping"] == -25.0  # (0 - 5)^2 on the clipped action
    _, _, _, _, info = env.step(np.array([1e6], dtype=np.float32))
    assert info["action"] == float(np.float32(491.61))
    assert info["unweighted_components"]["clipping"] < 0  # the lake's bound is lower than the box


def test_out_of_space_actions_raise_when_configured() -> None:
    env = DamEnv(invalid_action="raise")
    env.reset(seed=0)
    for bad in (-0.1, 600.0, float("inf")):
        with pytest.raises(ValueError, match="not in the action space"):
            env.step(np.array([bad]))
    env.step(np.array([491.61], dtype=np.float32))  # the bound itself is fine


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    actions=st.lists(st.floats(-100.0, 700.0), min_size=1, max_size=365),
    start=st.floats(-0.9, 3.0),
    fidelity=st.sampled_from(["corrected", "upstream"]),
)
def test_observations_stay_in_the_space_and_water_balances(
    seed: int, actions: list[float], start: float, fidelity: str
) -> None:
    env = DamEnv(fidelity=fidelity)
    obs, _ = env.reset(seed=seed, options={"init_level": start})
    assert env.observation_space.contains(obs)
    for a in actions:
        storage = env.storage
        obs, _, _, truncated, info = env.step(np.array([a], dtype=np.float32))
        assert env.observation_space.contains(obs)
        # daily mass balance: change of storage = 86400 s * (inflow - mean release)
        assert info["storage"] - storage == pytest.approx(86_400 * (info["inflow"] - info["release"]), abs=1.0)
        if truncated:
            break


def test_extreme_floods_stay_in_the_space() -> None:
    env = DamEnv(preset="test")
    env.reset(options={"year": 1952, "init_level": 5.0})  # far above any recorded level
    for _ in range(365):
        obs, *_ = env.step(np.array([0.0], dtype=np.float32))
        assert env.observation_space.contains(obs)


def test_corrected_and_upstream_agree_except_leap_days_and_the_last_observation() -> None:
    corrected, upstream = DamEnv(preset="test"), DamEnv(preset="test", fidelity="upstream")
    for year in TEST_YEARS:
        a, b = corrected.reset(options={"year": year})[0], upstream.reset(options={"year": year})[0]
        np.testing.assert_array_equal(a, b)
        same = True
        for t in range(365):
            act = np.array([180.0 + 100 * np.sin(t / 20)], dtype=np.float32)
            a, ra, *_, ia = corrected.step(act)
            b, rb, *_, ib = upstream.step(act)
            same &= ra == rb and ia["level"] == ib["level"]
            if t < 364:
                assert (a == b).all() or year in (1952, 1996)
        assert same == (year not in (1952, 1996))  # leap years: 29 February is dropped when corrected
        assert a[0] != b[0]  # the final observation: current level vs the reference's initial level


def test_each_fix_switches_alone() -> None:
    env = DamEnv(preset="test", fixes={"drop_feb29": False})
    up = DamEnv(preset="test", fidelity="upstream")
    env.reset(options={"year": 1996})
    up.reset(options={"year": 1996})
    for _ in range(365):
        a, ra, *_ = env.step(np.array([150.0], dtype=np.float32))
        b, rb, *_ = up.step(np.array([150.0], dtype=np.float32))
        assert ra == rb
    assert a[0] != b[0]  # the observation fix is still on
    env = DamEnv(fidelity="upstream", fixes={"current_level_observation": True}, doy=100)
    env.reset(seed=1)
    assert env.reset(seed=1)[1]["year"] == env.reset(seed=1)[1]["year"]


def test_inflow_follows_the_day_of_year_when_starting_later() -> None:
    env = DamEnv(preset="test", doy=100, sim_horizon=400)
    env.reset(options={"year": 1950})
    days, inflows = [], []
    for _ in range(400):
        *_, truncated, info = env.step(np.array([100.0], dtype=np.float32))
        days.append(info["day_of_year"])
        inflows.append(info["inflow"])
    assert days[:2] == [100, 101] and days[266] == 1  # wraps to 1 January of the same year's series
    assert inflows[0] == env.episode.inflow[0] == env._inflow.values[1950][99]
    assert truncated


def test_invalid_configs_say_what_to_fix() -> None:
    with pytest.raises(ConfigError, match="evaporation_rates"):
        DamEnv(lake={"evaporation": True})
    with pytest.raises(ConfigError, match="doy"):
        DamEnv(fidelity="upstream", doy=50)
    with pytest.raises(ConfigError, match="level_bounds"):
        DamEnv(level_bounds=(-1.0, 3.0))
    with pytest.raises(ConfigError, match="years"):
        DamEnv(years=[1950])  # a test year in the train split
    with pytest.raises(ConfigError, match="unknown field"):
        DamEnv(surface=1.0)


def test_evaporation_from_a_rates_file(tmp_path: object) -> None:
    from pathlib import Path

    rates = Path(str(tmp_path)) / "evaporation.csv"
    rates.write_text("rate_mm_per_day\n" + "\n".join(["2.0"] * 365) + "\n")
    env = DamEnv(preset="test", lake={"evaporation": True, "evaporation_rates": str(rates)})
    dry = DamEnv(preset="test")
    env.reset(options={"year": 1950})
    dry.reset(options={"year": 1950})
    flow = 2.0 / 1000 * 145.9e6 / 86_400  # 3.38 m3/s
    for _ in range(15):
        *_, info = env.step(np.array([100.0], dtype=np.float32))
        *_, dry_info = dry.step(np.array([100.0], dtype=np.float32))
        assert info["release"] == dry_info["release"] == 100.0  # the decision stays feasible
    # 15 days of 2 mm/day
    assert dry_info["level"] - info["level"] == pytest.approx(15 * 86_400 * flow / 145.9e6, rel=1e-6)
    assert dry_info["level"] - info["level"] == pytest.approx(0.030, rel=1e-6)


@pytest.mark.parametrize("preset", ["train", "test"])
def test_realistic_evaporation_passes_the_level_bounds_check(tmp_path: Path, preset: str) -> None:
    """3 mm/day (Lake Como's summer rate) fits the default bounds: below l_min the inflow exceeds it."""
    rates = tmp_path / "evaporation.csv"
    rates.write_text("rate_mm_per_day\n" + "\n".join(["3.0"] * 365) + "\n")
    env = DamEnv(preset=preset, lake={"evaporation": True, "evaporation_rates": str(rates)})
    assert env.config.level_bounds == (-1.0, 6.0)


def test_the_low_level_bound_holds_for_a_lake_draining_by_evaporation(tmp_path: Path) -> None:
    """With 100 mm/day (169 m3/s, above most inflows) the lake falls below l_min, never below the bound."""
    rates = tmp_path / "evaporation.csv"
    rates.write_text("rate_mm_per_day\n" + "\n".join(["100.0"] * 365) + "\n")
    lake = {"evaporation": True, "evaporation_rates": str(rates)}
    with pytest.raises(ConfigError, match="level_bounds"):
        DamEnv(preset="test", lake=lake)
    env = DamEnv(preset="test", lake=lake, level_bounds=(-40, 6))
    low, _ = env.lake.level_range(-0.5, env.config.max_inflow, env._evaporation_drop(env.lake.surface, 1.0))
    lowest = math.inf
    for year in env.years:
        env.reset(options={"year": year, "init_level": -0.5})
        truncated = False
        while not truncated:
            *_, truncated, info = env.step(np.array([0.0], dtype=np.float32))
            lowest = min(lowest, info["level"])
    assert low <= lowest < -0.5 - 0.5 * (-0.5 - low)  # reached: the bound is within a factor 2 of the data


def test_an_episode_past_31_december_continues_in_the_next_year_of_the_split() -> None:
    env = DamEnv(preset="test", doy=200)
    inflow = env._inflow.values
    for year, expected in ((1970, 1971), (1950, 1950)):  # 1971 is a test year, 1951 a training year
        env.reset(options={"year": year})
        for _ in range(365 - 199):
            *_, info = env.step(np.array([100.0], dtype=np.float32))
        assert info["day_of_year"] == 365 and info["calendar_year"] == year
        *_, info = env.step(np.array([100.0], dtype=np.float32))
        assert info["day_of_year"] == 1 and info["calendar_year"] == expected
        assert info["inflow"] == inflow[expected][0]
        assert info["year"] == year


def test_multi_objective_id_gives_the_five_components() -> None:
    env = gym.make("gym4real/dam-mo-v0")
    env.reset(seed=0)
    _, vector, *_, info = env.step(np.array([100.0], dtype=np.float32))
    assert vector.shape == (5,)
    assert vector.sum() == pytest.approx(info["scalar_reward"])


def test_render_ansi() -> None:
    env = DamEnv(render_mode="ansi", preset="test")
    env.reset()
    assert env.render().startswith("1950 day   1 start: level +0.350 m")
