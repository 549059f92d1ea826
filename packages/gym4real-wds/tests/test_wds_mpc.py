"""The model-predictive controller: causal, its forecast and demand recovery, its search, its cache."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gym4real.bench.benchmark import run_episode
from gym4real.cli import main
from gym4real.core.errors import PolicyError
from gym4real.core.registry import registry
from gym4real.wds import demand
from gym4real.wds.env import WDSEnv
from gym4real.wds.hindsight import WDSHindsight
from gym4real.wds.mpc import WDSMPC, forecast, training_shape

ENV_ID = "gym4real/wds-v0"
OBJECTIVE = ("dsr", "overflow")
DAY = 24


def _actions(env: WDSEnv, policy: WDSMPC, pattern: np.ndarray) -> list[int]:
    """The controller's actions over an episode of ``pattern``."""
    obs, _ = env.reset(options={"pattern": pattern})
    policy.reset(None)
    actions, done = [], False
    while not done:
        actions.append(int(policy(obs)))
        obs, _, _, done, _ = env.step(actions[-1])
    return actions


def test_mpc_is_registered_as_a_causal_baseline(capsys: pytest.CaptureFixture[str]) -> None:
    assert registry().baselines[ENV_ID]["mpc"].causal is True
    assert main(["info", ENV_ID, "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert "mpc" in record["baselines"] and "mpc" not in record["non_causal"]


@pytest.mark.parametrize("estimate", ["sma", "ewma"])
@pytest.mark.parametrize("window", [1, 6, 24])
def test_multipliers_invert_the_demand_estimates(estimate: str, window: int) -> None:
    pattern = demand.load().test[:, 7]
    run = demand.moving_average if estimate == "sma" else demand.exp_moving_average
    np.testing.assert_allclose(demand.multipliers(run(pattern, window), estimate, window), pattern, atol=1e-12)
    with pytest.raises(ValueError, match="`estimate`"):
        demand.multipliers(pattern, "median", window)


def test_the_observed_estimates_give_back_the_multipliers_so_far() -> None:
    """What the controller reads: the float32 demand estimates of the observations, from the reset on."""
    env = WDSEnv(preset="test")
    try:
        obs, _ = env.reset(options={"profile_index": 3})
        seen = [float(obs[-3])]
        for _ in range(40):
            obs, *_ = env.step(3)
            seen.append(float(obs[-3]))
        recovered = demand.multipliers(np.array(seen), "sma", env.config.demand.window)
        np.testing.assert_allclose(recovered, env._pattern[:41], atol=1e-5)
    finally:
        env.close()


def test_forecast_is_the_past_days_mean_with_the_scaled_shape_as_one_more_day() -> None:
    shape = np.linspace(0.5, 1.5, DAY)
    level = 0.4
    periodic = np.tile(level * shape, 3)
    # a demand of the shape's form: every day, and the scaled shape, say the same
    np.testing.assert_allclose(forecast(periodic[:30], DAY, shape), periodic[30:54], rtol=1e-12)
    # brute force on noisy days: hour 30 (hour of day 6) has past days 6 and 30 - 24 = 6 only
    rng = np.random.default_rng(0)
    past = level * np.tile(shape, 2)[:30] + rng.normal(0, 0.05, 30)
    scaled = past.sum() / np.tile(shape, 2)[:30].sum() * shape
    want = [(past[h % DAY :: DAY].sum() + scaled[h % DAY]) / (len(past[h % DAY :: DAY]) + 1) for h in range(30, 54)]
    np.testing.assert_allclose(forecast(past, DAY, shape), want, rtol=1e-12)
    with pytest.raises(PolicyError, match="at most 24 hours"):
        forecast(past, DAY + 1, shape)


def test_training_shape_has_mean_one_and_the_morning_peak() -> None:
    shape = training_shape(demand.load(), DAY)
    assert shape.mean() == pytest.approx(1.0)
    assert 6 <= int(np.argmax(shape)) <= 9 and int(np.argmin(shape)) <= 4  # morning peak, night trough


@pytest.mark.parametrize("t", [4, 11, 17])
def test_actions_up_to_t_do_not_depend_on_the_demand_after_t(t: int) -> None:
    """Causality: two demands equal up to hour t give the same actions up to t; the action after t differs."""
    env = WDSEnv(preset="test", duration=DAY * 3600)
    try:
        policy = WDSMPC(env, horizon=6, cadence=1, width=2, cache=False)  # replans at every decision
        base = demand.load().test[:DAY, 4].copy()
        future = base.copy()
        future[t + 1 :] = 1.0  # the highest demand of the profiles from hour t + 1 on
        first, second = _actions(env, policy, base), _actions(env, policy, future)
        assert first[: t + 1] == second[: t + 1]
        assert first[t + 1] != second[t + 1]  # it reacts to the demand the moment it sees it
        policy.close()
    finally:
        env.close()


def test_a_demand_the_forecast_knows_gives_the_hindsight_search_schedule() -> None:
    """On the training shape scaled, the forecast is exact: one plan of the whole day is the planner's search."""
    env = WDSEnv(preset="test", duration=DAY * 3600)
    try:
        pattern = 0.45 * training_shape(env.profiles, DAY)
        mpc = WDSMPC(env, horizon=DAY, cadence=DAY, cache=False)
        planner = WDSHindsight(env)
        planned = _actions(env, mpc, pattern)
        hindsight = run_episode(env, planner, 0, {"pattern": pattern}, objective=OBJECTIVE)
        assert tuple(planned) == planner.schedule and planner.source == "search"
        ours = run_episode(env, mpc, 0, {"pattern": pattern}, objective=OBJECTIVE)
        assert ours["objective_rewards"].sum() == pytest.approx(hindsight["objective_rewards"].sum(), abs=1e-9)
        mpc.close()
        planner.close()
    finally:
        env.close()


def test_schedules_are_cached_per_episode_and_replayed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path))
    env = WDSEnv(preset="test", duration=DAY * 3600)
    try:
        pattern = demand.load().test[:DAY, 2]
        first = WDSMPC(env, horizon=6, cadence=3, width=2)
        planned = _actions(env, first, pattern)
        (stored,) = tmp_path.rglob("*.json")
        assert list(json.loads(stored.read_text())["plans"].values()) == [planned]
        again = WDSMPC(env, horizon=6, cadence=3, width=2)
        assert _actions(env, again, pattern) == planned and again._copies == []  # replayed, not planned
        other = WDSMPC(env, horizon=6, cadence=2, width=2)  # another controller: another entry
        _actions(env, other, pattern)
        assert len(json.loads(stored.read_text())["plans"]) == 2
        for policy in (first, other):
            policy.close()
    finally:
        env.close()


def test_bad_envs_and_arguments_are_refused() -> None:
    env = WDSEnv(fidelity="upstream")
    try:
        with pytest.raises(PolicyError, match="corrected mode"):
            WDSMPC(env)
    finally:
        env.close()
    env = WDSEnv(preset="test")
    try:
        with pytest.raises(PolicyError, match="`horizon` must be in"):
            WDSMPC(env, horizon=25)
        with pytest.raises(PolicyError, match="`cadence`"):
            WDSMPC(env, horizon=4, cadence=5)
        policy = WDSMPC(env, horizon=4, cadence=2, width=1, cache=False)
        obs, _ = env.reset(options={"profile_index": 0})
        policy(obs)
        obs, *_ = env.step(0)
        obs, *_ = env.step(0)
        with pytest.raises(PolicyError, match="at every decision"):
            policy(obs)
        policy.close()
    finally:
        env.close()
