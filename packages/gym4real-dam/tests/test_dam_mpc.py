from __future__ import annotations

import calendar
import dataclasses
import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest

import gym4real
from gym4real.bench import stats
from gym4real.bench.upper_reference import check_protocol
from gym4real.core.errors import ConfigError
from gym4real.dam.forecast import SeriesForecast, series_forecast
from gym4real.dam.hindsight import DamHindsight
from gym4real.dam.mpc import DamMPC

pytest.importorskip("numba")

ENV = "gym4real/dam-v0"
TRAIN_INFLOW = Path(os.environ["GYM4REAL_DATA_DIR"]) / "dam" / "inflow" / "water_inflow_train.csv"
PAPER = Path(__file__).resolve().parents[3] / "docs" / "results" / "dam-v0-paper" / "episodes.csv"


def _actions(env: gym.Env, policy: DamMPC | DamHindsight, year: int, days: int) -> list[float]:
    obs, _ = env.reset(options={"year": year})
    policy.reset(None)
    actions = []
    for _ in range(days):
        action = policy(obs)
        actions.append(float(action[0]))
        obs, *_ = env.step(action)
    return actions


def _change_the_future(env: gym.Env, year: int, t: int) -> None:
    """From day ``t`` on, a flood of inflow and half the demand in the env's series of ``year`` (before its reset)."""
    raw = env.unwrapped
    episode = raw._episode(year)
    inflow = episode.inflow[:t] + tuple(3.0 * q + 200.0 for q in episode.inflow[t:])
    demand = episode.demand[:t] + tuple(0.5 * d for d in episode.demand[t:])
    raw._episodes[year] = dataclasses.replace(episode, inflow=inflow, demand=demand)
    raw._episode_rows[year] = [
        (d, q, *row[2:]) for d, q, row in zip(demand, inflow, raw._episode_rows[year], strict=True)
    ]


# -- causality ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("t", [0, 9, 25])
def test_the_actions_up_to_a_day_do_not_depend_on_the_inflow_and_demand_from_that_day_on(t: int) -> None:
    """Two episodes whose inflow and demand differ from day ``t`` on: the controller's releases of days 0..t are
    the same, and it reacts to what it observes afterwards. The hindsight planner, which reads the future, does
    not pass this test (its releases before ``t`` change): the change is one a peeking controller would see."""
    days, year = 40, 1970
    runs: dict[str, list[list[float]]] = {"mpc": [], "hindsight": []}
    for changed in (False, True):
        env = gym.make(ENV, preset="test", sim_horizon=days)
        if changed:
            _change_the_future(env, year, t)
        runs["mpc"].append(_actions(env, DamMPC(env, cache=False), year, days))
        runs["hindsight"].append(_actions(env, DamHindsight(env, step=0.01, cache=False), year, days))
    same, other = runs["mpc"]
    assert same[: t + 1] == other[: t + 1]
    assert same[t + 1 :] != other[t + 1 :]
    assert runs["hindsight"][0][: t + 1] != runs["hindsight"][1][: t + 1]


def test_the_decisions_of_an_episode_are_cached_and_replayed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path))
    env = gym.make(ENV, preset="test", sim_horizon=12)
    first = _actions(env, DamMPC(env), 1970, 12)
    (cache,) = (tmp_path / "hindsight").glob("*mpc*.json")
    again = DamMPC(env)
    again._solve = None  # type: ignore[assignment,method-assign]  # a cache miss would call it and fail
    assert _actions(env, again, 1970, 12) == first
    _change_the_future(env, 1970, 11)  # another episode (its last day differs): not in the cache
    with pytest.raises(TypeError):
        _actions(env, again, 1970, 12)
    assert cache.is_file()


# -- the forecasts -----------------------------------------------------------------------------------------------


def _training_inflow(leave_out: int | None = None) -> np.ndarray:
    """The training file's inflow by day of year, 29 February dropped, read here without the package's reader."""
    table = pd.read_csv(TRAIN_INFLOW, index_col="year")
    rows = []
    for year, values in table.iterrows():
        if year == leave_out:
            continue
        series = values.dropna().to_numpy()
        rows.append(np.delete(series, 59) if calendar.isleap(int(year)) and series.size == 366 else series)
    return np.array(rows)


def test_the_climatology_is_each_days_mean_over_the_training_years_only() -> None:
    """A test-split env's controller forecasts from the training file (never the test years'); on the train
    split an episode's own year is left out of its forecast."""
    test_env = gym.make(ENV, preset="test")
    inflow, _ = DamMPC(test_env, cache=False).forecasts()
    np.testing.assert_allclose(inflow.climatology, _training_inflow().mean(axis=0), rtol=1e-12)

    train_env = gym.make(ENV, preset="validation", sim_horizon=3)
    policy = DamMPC(train_env, cache=False)
    _actions(train_env, policy, 1985, 1)
    assert policy._forecasts is not None
    np.testing.assert_allclose(policy._forecasts[0].climatology, _training_inflow(1985).mean(axis=0), rtol=1e-12)


def test_the_persistence_of_an_ar1_anomaly_is_its_coefficient_to_the_power_of_the_lag() -> None:
    rng = np.random.default_rng(0)
    rho, years = 0.8, 400
    anomaly = np.zeros((years, 365))
    anomaly[:, 0] = rng.normal(size=years) / np.sqrt(1 - rho**2)
    for d in range(1, 365):
        anomaly[:, d] = rho * anomaly[:, d - 1] + rng.normal(size=years)
    seasonal = 100.0 + 50.0 * np.sin(np.arange(365) * 2 * np.pi / 365)
    fitted = series_forecast(seasonal + anomaly, "mean", 5)
    np.testing.assert_allclose(fitted.persistence, rho ** np.arange(1, 6), atol=0.01)
    np.testing.assert_allclose(fitted.climatology, seasonal, atol=0.5)


def test_a_forecast_carries_the_last_anomaly_for_its_lags_then_is_the_climatology() -> None:
    forecast = SeriesForecast(np.full(365, 10.0), np.array([0.5, 0.25]))
    np.testing.assert_array_equal(forecast.predict([5, 6, 7, 8], None, None), [10.0] * 4)
    np.testing.assert_array_equal(forecast.predict([5, 6, 7, 8], 14.0, 4), [12.0, 11.0, 10.0, 10.0])
    np.testing.assert_array_equal(forecast.predict([364, 0], -30.0, 363), [0.0, 0.0])  # floored at 0
    values = np.arange(365 * 3, dtype=float).reshape(3, 365)
    np.testing.assert_array_equal(series_forecast(values, 0.5, 0).climatology, np.median(values, axis=0))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"statistic": "median"}, "statistic"),
        ({"statistic": 1.5}, "statistic"),
        ({"statistic": True}, "statistic"),
        ({"horizon": 0}, "horizon"),
        ({"horizon": 365}, "horizon"),
        ({"cadence": 31, "horizon": 30}, "cadence"),
        ({"margins": (-0.1, 0.0)}, "margins"),
        ({"margins": (1.0, 1.0)}, "margins"),
        ({"step": 0.0}, "step"),
    ],
)
def test_bad_settings_name_the_field(kwargs: dict, field: str) -> None:
    env = gym.make(ENV, preset="test", sim_horizon=3)
    with pytest.raises(ConfigError, match=field):
        DamMPC(env, **kwargs)


# -- the programme's terminal value and the registration ---------------------------------------------------------


def test_a_programme_ending_on_the_values_of_its_tail_is_the_whole_programme() -> None:
    """Bellman's principle on the grid: planning days 0..9 onto the value function of days 10..19 gives the value
    function of the 20 days, bit for bit."""
    from gym4real.dam.hindsight_kernel import backward

    env = gym.make(ENV, preset="test", sim_horizon=20)
    env.reset(options={"year": 1994})
    planner = DamHindsight(env, step=0.01, cache=False)
    c = planner._constants()
    low, points = planner._grid(c)
    decisions, counts = planner._candidates(c)
    rows = c["exogenous"]

    def programme(days: slice, terminal: np.ndarray | None) -> np.ndarray:
        args = (c["lake"], c["evaporates"], c["substeps"], c["costs"], terminal)
        return backward(low, 0.01, points, decisions[days], counts[days], rows[days], *args)

    whole = programme(slice(0, 20), None)
    tail = programme(slice(10, 20), None)
    np.testing.assert_array_equal(programme(slice(0, 10), tail[0]), whole[:11])
    assert np.any(whole[10] != 0.0)


def test_mpc_is_registered_as_a_causal_baseline() -> None:
    info = gym4real.env_info(ENV)
    assert "mpc" in info.baselines and "mpc" not in info.non_causal
    check_protocol(ENV)


@pytest.mark.slow
def test_mpc_is_between_the_best_rule_and_hindsight_on_the_test_years() -> None:
    """On the IQM of the 13 test years; ``hindsight``'s test episodes from the published paper section."""
    result = gym4real.benchmark(ENV, ["mpc", "max"], "test")
    published = pd.read_csv(PAPER)
    upper = published[published["policy"] == "hindsight"].sort_values("episode")["objective"].to_numpy()
    assert (
        stats.iqm(result.objective_values("max")) < stats.iqm(result.objective_values("mpc")) < stats.iqm(upper[None])
    )
