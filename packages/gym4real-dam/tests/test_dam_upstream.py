"""``fidelity="upstream"`` against the reference behaviour.

``SpecLake`` below transcribes the spec's description of the reference step by step (plain loops,
``numpy.mean``, the reference's expressions), independently of the package's fast integrator. The
hard-coded means were obtained by running the reference implementation (Gym4ReaL v1.0, commit 774d5ce,
``world_test.yaml``, the evaluation loop of its benchmark notebook) on the same data files.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gym4real.core.datasets import resolve
from gym4real.dam import DamEnv
from gym4real.dam.data import read_daily_column, read_yearly
from gym4real.dam.evaluation import TEST_YEARS

HIGH = float(np.float32(491.61))
MID = float(np.float32(HIGH / 2))


class SpecLake:
    """The reference DamEnv as the spec describes it (test config, default options)."""

    def __init__(self) -> None:
        demand = read_yearly(resolve("dam/demand/test"), "demand")
        inflow = read_yearly(resolve("dam/inflow/test"), "inflow")
        self.demand, self.inflow = demand.values, inflow.values
        self.mef = np.array(read_daily_column(resolve("dam/mef"), "MEF", "MEF"))

    def q_min(self, h: float, day: int) -> float:
        if h <= -0.5:
            return 0.0
        if h <= 1.25:
            return self.mef[day - 1]
        return 33.37 * ((h - -2.5) ** 2.015)

    def q_max(self, h: float) -> float:
        if h <= -0.5:
            return 0.0
        if h <= -0.4:
            return 1488.1 * h + 744.05
        return 33.37 * ((h - -2.5) ** 2.015)

    def episode(self, year: int, policy: str) -> tuple[list[float], list[np.ndarray], float]:
        storage, level, ead = 145900000 * (0.35 - -0.5), 0.35, 0.0
        levels, rewards, observations, objective = [level], [], [], 0.0
        for t in range(365):
            a = {"mean": MID, "max": HIGH, "ead": ead}[policy]
            day = (1 + t - 1) % 365 + 1
            d = self.demand[year][day - 1]
            ead = 0.8 * ead + (1 - 0.8) * d
            inflow = self.inflow[year][t]
            releases, s = [], storage
            for _ in range(24):
                h = s / 145900000 + -0.5
                releases.append(min(self.q_max(h), max(self.q_min(h, day), a)))
                s = s + 86400 / 24 * (inflow - releases[-1] - 0.0)
            storage, q = s, np.mean(releases)
            level = storage / 145900000 + -0.5
            levels.append(level)
            doy = day - 1
            qdiv = max(q - self.mef[doy], 0.0)
            deficit = max(d - qdiv, 0.0) * (0.5 * (3 - math.cos(doy * 2 * math.pi / 365)))
            terms = {
                "overflow": -int(level > 1.24) * 1000,
                "starving": -int(level < -0.45) * 250,
                "deficit": -deficit * 1,
                "wasted": -max(q - d, 0.0) * 0.2,
                "clipping": -((a - q) ** 2) * 0.0005,
            }
            total = 0.0
            for value in terms.values():
                total += value
            rewards.append(total)
            objective += terms["overflow"] + terms["starving"] + terms["deficit"]
            obs_day = (1 + t + 1 - 1) % 365
            observations.append(
                np.array(
                    [
                        levels[obs_day],
                        math.sin(2 * math.pi * obs_day / 365),
                        math.cos(2 * math.pi * obs_day / 365),
                        ead,
                    ],
                    dtype=np.float32,
                )
            )
        return rewards, observations, objective


def run(env: DamEnv, year: int, policy: str) -> tuple[list[float], list[np.ndarray], float]:
    env.reset(options={"year": year})
    rewards, observations, objective, done = [], [], 0.0, False
    base = env.unwrapped
    while not done:
        a = {"mean": MID, "max": HIGH, "ead": base.exponential_average_demand}[policy]
        obs, reward, _, done, info = env.step(np.array([a]))
        rewards.append(reward)
        observations.append(obs)
        comps = info["reward_components"]
        objective += comps["overflow"] + comps["starving"] + comps["deficit"]
    return rewards, observations, objective


@pytest.mark.parametrize("policy", ["mean", "max", "ead"])
def test_upstream_is_bit_identical_to_the_spec_transcription(policy: str) -> None:
    spec, env = SpecLake(), DamEnv(preset="test", fidelity="upstream")
    for year in TEST_YEARS[::3]:
        expected, got = spec.episode(year, policy), run(env, year, policy)
        assert got[0] == expected[0]  # every reward, exactly
        for a, b in zip(got[1], expected[1], strict=True):
            np.testing.assert_array_equal(a, b)
        assert got[2] == expected[2]


# Mean over the 13 test years of the return and of the objective (deficit + overflow + starving),
# from the reference implementation.
REFERENCE = {
    "mean": (-32505.208703335782, -28838.41296173343),
    "max": (-43370.02678801743, -20492.9408927114),
    "ead": (-25960.79275104119, -25179.66071402502),
}


@pytest.mark.parametrize("policy", sorted(REFERENCE))
def test_upstream_reproduces_the_reference_baseline_scores(policy: str) -> None:
    env = DamEnv(preset="test", fidelity="upstream")
    runs = [run(env, year, policy) for year in TEST_YEARS]
    assert np.mean([sum(r[0]) for r in runs]) == pytest.approx(REFERENCE[policy][0], rel=1e-12)
    assert np.mean([r[2] for r in runs]) == pytest.approx(REFERENCE[policy][1], rel=1e-12)


def test_upstream_info_keeps_the_reference_keys() -> None:
    env = DamEnv(preset="test", fidelity="upstream")
    env.reset()
    action = np.array([100.0], dtype=np.float32)
    *_, info = env.step(action)
    # the raw input (not clipped nor cast), as the reference; a copy, so that infos never share an object
    assert info["action"].dtype == action.dtype
    np.testing.assert_array_equal(info["action"], action)
    assert set(info["pure_reward"]) == {
        "overflow_reward",
        "starving_reward",
        "daily_deficit_reward",
        "wasted_water_reward",
        "clipping_reward",
    }
    assert info["reward"] == sum(info["weighted_reward"].values())


def test_upstream_info_does_not_hold_the_callers_action_object() -> None:
    """A policy that returns the same array every step (a constant baseline) must not make two infos share it."""
    env = DamEnv(fidelity="upstream")
    env.reset(seed=0)
    action = np.array([50.0], dtype=np.float32)
    first = env.step(action)[4]
    second = env.step(action)[4]
    assert first["action"] is not action and second["action"] is not first["action"]
    np.testing.assert_array_equal(second["action"], action)
