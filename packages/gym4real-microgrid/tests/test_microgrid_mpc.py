"""The causal MPC: its forecasts, its causality, its tracking of the plan, its cache and its registration."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gym4real.bench.benchmark import run_episode
from gym4real.cli import main
from gym4real.core.errors import PolicyError
from gym4real.core.registry import registry
from gym4real.microgrid import MicrogridEnv
from gym4real.microgrid.hindsight import _episode_data
from gym4real.microgrid.mpc import DAY, WEEK, MicrogridMPC, Profile

pytest.importorskip("numba")

ENV_ID = "gym4real/microgrid-v0"
OBJECTIVE = ("trading", "degradation")
#: 17 June 2019, 00:00: four summer days, PV surplus at noon, deficit at night.
JUNE = 24 * 167


class _Truth(MicrogridMPC):
    """The MPC handed the episode's own series as its forecast (the plan's hours are the env's)."""

    def forecast(self, k: int, n: int) -> dict[str, np.ndarray]:
        return {key: value[:n] for key, value in _episode_data(self.env).items()}


def _actions(env: MicrogridEnv, policy: MicrogridMPC, start: int = JUNE, profile: str = "375") -> list[float]:
    run_episode(env, policy, 0, {"profile": profile, "start": start}, objective=OBJECTIVE)
    return list(policy._actions)


def test_mpc_is_registered_as_causal_and_info_lists_it(capsys: pytest.CaptureFixture[str]) -> None:
    assert registry().baselines[ENV_ID]["mpc"].causal is True
    assert main(["info", ENV_ID, "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert "mpc" in info["baselines"] and "mpc" not in info["non_causal"] and "hindsight" in info["non_causal"]


def test_profile_averages_the_latest_observed_hours_of_its_period() -> None:
    history = np.arange(100.0)  # hour h observed as h; hours 0..99 seen
    day = Profile(DAY, 2)
    # hour 100: hours 76 and 52; hour 123: 99 and 75; hour 124: 76 and 52 (100 is not observed yet)
    np.testing.assert_allclose(day(history, np.array([100, 123, 124])), [64.0, 87.0, 64.0])
    np.testing.assert_allclose(day(history, np.array([5, 99])), [5.0, 99.0])  # observed hours are themselves
    # a week's profile before a week has passed: the same hour of the past days instead
    np.testing.assert_allclose(Profile(WEEK, 4)(history, np.array([100])), [(76 + 52 + 28 + 4) / 4])
    np.testing.assert_allclose(Profile(WEEK, 4)(np.arange(400.0), np.array([400])), [(232 + 64) / 2])
    # an hour of the day not observed yet: the last value (persistence, which is period 1 count 1 itself)
    np.testing.assert_allclose(day(history[:10], np.array([10, 30])), [9.0, 6.0])
    np.testing.assert_allclose(Profile(1, 1)(history, np.array([100, 150])), [99.0, 99.0])


@pytest.mark.parametrize(("field", "value"), [("period", 0), ("count", 0)])
def test_profile_refuses_an_empty_window(field: str, value: int) -> None:
    kwargs = {"period": DAY, "count": 1, field: value}
    with pytest.raises(PolicyError, match="period >= 1 and count >= 1"):
        Profile(**kwargs)


@pytest.mark.parametrize(("horizon", "cadence"), [(0, 1), (24, 0), (24, 25)])
def test_horizon_and_cadence_out_of_range_are_refused(horizon: int, cadence: int) -> None:
    with pytest.raises(PolicyError, match=f"not horizon {horizon}, cadence {cadence}"):
        MicrogridMPC(MicrogridEnv(preset="test", max_steps=24), horizon=horizon, cadence=cadence, cache=False)


def test_actions_up_to_an_hour_do_not_depend_on_the_data_after_it() -> None:
    """A future (demand, PV, prices) that differs from hour t on leaves every action before hour t unchanged."""
    hours, t = 24 * 4, 24 + 13  # the second day's 13:00: a plan was made at 24:00 and is being tracked
    base = MicrogridEnv(preset="test", max_steps=hours)
    reference = _actions(base, MicrogridMPC(base, cache=False))

    class Altered(MicrogridEnv):
        """The env whose demand, PV and prices differ from episode hour ``t`` on (the rows the agent has not seen)."""

        def reset(self, **kwargs):  # type: ignore[no-untyped-def]
            out = super().reset(**kwargs)
            row = self._row + t
            self._demand = [v * (3.0 if i >= row else 1.0) for i, v in enumerate(self._demand)]
            self._pv = [v * (0.2 if i >= row else 1.0) for i, v in enumerate(self._pv)]
            self._ask = [v * (2.0 if i >= row else 1.0) for i, v in enumerate(self._ask)]
            self._bid = [v * (0.5 if i >= row else 1.0) for i, v in enumerate(self._bid)]
            return out

    altered = Altered(preset="test", max_steps=hours)
    changed = _actions(altered, MicrogridMPC(altered, cache=False))
    assert changed[:t] == reference[:t]
    assert changed[t:] != reference[t:]  # the altered future does reach the controller once revealed


def test_with_the_true_series_the_twin_follows_the_plan() -> None:
    """The fraction of the forecast net power takes the twin's SoC to the plan's target when the forecast is right."""
    env = MicrogridEnv(preset="test", max_steps=DAY)
    policy = _Truth(env, horizon=DAY, cadence=DAY, cache=False)
    obs, _ = env.reset(seed=0, options={"profile": "375", "start": JUNE})
    reached = []
    for _ in range(DAY):
        obs, _, _, _, info = env.step(policy(obs))
        reached.append(info["soc"])
    targets = policy._targets[1:]
    assert np.ptp(targets) > 0.05  # the plan charges and discharges
    np.testing.assert_allclose(reached, targets, atol=1e-6)


def test_mpc_needs_the_episode_from_its_first_hour() -> None:
    env = MicrogridEnv(preset="test", max_steps=48)
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(np.zeros(1, np.float32))
    with pytest.raises(PolicyError, match="first hour"):
        MicrogridMPC(env, cache=False)(obs)


def test_cached_actions_replay_the_episode(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path))
    env = MicrogridEnv(preset="test", max_steps=48)
    policy = MicrogridMPC(env)
    first = run_episode(env, policy, 0, {"profile": "375", "start": JUNE}, objective=OBJECTIVE)
    assert policy._cache.path is not None and policy._cache.path.is_file()
    replayed = MicrogridMPC(env)

    def never(k: int) -> None:
        raise AssertionError("a cached episode is replayed, never planned")

    monkeypatch.setattr(replayed, "_plan", never)
    again = run_episode(env, replayed, 0, {"profile": "375", "start": JUNE}, objective=OBJECTIVE)
    np.testing.assert_array_equal(again["rewards"], first["rewards"])
    # another household is another key: planned, not replayed
    other = MicrogridMPC(env)
    run_episode(env, other, 0, {"profile": "376", "start": JUNE}, objective=OBJECTIVE)
    assert other._replaying is None and len(other._actions) == 48
