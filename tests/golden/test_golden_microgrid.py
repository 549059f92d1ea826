"""MicrogridEnv ``fidelity="upstream"`` against the reference's own numbers (``microgrid.json``).

The fixture holds the full protocol (28 test profiles x only-market, battery-first, 50-50, 8759 hourly
steps each, with the reference's settings: reward normalisation on, weights 1 / 1 / 0.1, i.e. our default
preset); the tests run all of it (a few seconds per baseline).

Tolerances (exact: step counts and flags):

* per-episode returns, component sums and final SoH: ``rtol`` 1e-12 with ``atol`` 1e-10 EUR (largest
  relative difference over the 84 episodes 4.0e-13, except the trading sum of household 373 under
  only-market, 0.09 EUR out of terms of up to a few EUR, which differs by 1.4e-11). The reference reads the
  data files with pandas 2.2's default float parser, which is not correctly rounded (3,523 of the 26,280
  market prices, 603 demand values, 171 PV values one ulp off); pandas >= 3, our parser, rounds correctly.
  Fed the reference's parsed values, the largest difference is 8.8e-14 (the degradation sum): NumPy's and
  the C library's ``exp`` and the order of a few sums differ in the last bit.
* per step: rewards and the degradation term ``atol`` 4e-12, two ulps of a SoH near 1 times the 7,500 EUR
  per unit of SoH (the term is a difference of two SoH values); the other terms ``rtol`` 1e-12;
  observations (float32) ``rtol`` 1.2e-7 (one float32 ulp) and ``atol`` 1e-15 (the time features near 0).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from gym4real.microgrid import evaluation
from gym4real.microgrid.baselines import battery_first, fifty_fifty, only_market

ENV_ID = "gym4real/microgrid-v0"
KWARGS = {"fidelity": "upstream"}  # the default preset: the reference's world_test.yaml settings
BASELINES = {"only_market": only_market, "battery_first": battery_first, "fifty_fifty": fifty_fifty}
# our pure component names -> the reference's keys of info["pure_rewards"]
NAMES = {"trading": "r_trad", "degradation": "r_deg", "clipping": "r_clip"}
RTOL = 1e-12
SUM_ATOL = 1e-10
STEP_ATOL = 4e-12
OBS_RTOL, OBS_ATOL = 1.2e-7, 1e-15


def _run(name: str, profiles: list[str]) -> dict[str, list[float]]:
    env = gym.make(ENV_ID, **KWARGS)
    policy = BASELINES[name](env)
    episodes = [ep for ep in evaluation.test_episodes(KWARGS) if ep["options"]["profile"] in profiles]
    got: dict[str, list[float]] = {"steps": [], "return": [], "soh": [], **{k: [] for k in NAMES}}
    for ep in episodes:
        obs, _ = env.reset(seed=ep["seed"], options=ep["options"])
        rewards, sums, done = [], dict.fromkeys(NAMES, 0.0), False
        while not done:
            obs, reward, terminated, truncated, info = env.step(policy(obs))
            rewards.append(reward)
            for k in NAMES:
                sums[k] += info["pure_components"][k]
            done = terminated or truncated
        got["steps"].append(len(rewards))
        got["return"].append(math.fsum(rewards))
        got["soh"].append(info["battery"]["soh"])
        for k in NAMES:
            got[k].append(sums[k])
    return got


def _compare(name: str, want: dict[str, Any], profiles: list[str]) -> None:
    index = [want["profile"].index(p) for p in profiles]
    got = _run(name, profiles)
    assert got["steps"] == [want["steps"][i] for i in index]
    for key in ("return", "soh"):
        ref = [want[key][i] for i in index]
        np.testing.assert_allclose(got[key], ref, rtol=RTOL, atol=SUM_ATOL, err_msg=f"{name} {key}")
    for ours, theirs in NAMES.items():
        ref = [want["components"][theirs][i] for i in index]
        np.testing.assert_allclose(got[ours], ref, rtol=RTOL, atol=SUM_ATOL, err_msg=f"{name} {ours}")


@pytest.mark.parametrize("name", sorted(BASELINES))
def test_upstream_baselines_match_the_reference(golden: Callable[[str], dict[str, Any]], name: str) -> None:
    _compare(name, golden("microgrid")["baselines"][name], list(evaluation.TEST_PROFILES))


def test_upstream_trajectory_matches_the_reference(golden: Callable[[str], dict[str, Any]]) -> None:
    want = golden("microgrid")["trajectory"]
    env = gym.make(ENV_ID, **KWARGS)
    obs, _ = env.reset(options={"profile": want["profile"]})
    np.testing.assert_array_equal(obs, np.array(want["steps"][0]["obs"], dtype=np.float32))
    for action, step in zip(want["actions"], want["steps"][1:], strict=True):
        obs, reward, terminated, truncated, info = env.step(np.array([action]))
        ref_obs = np.array(step["obs"], dtype=np.float32)
        np.testing.assert_allclose(obs, ref_obs, rtol=OBS_RTOL, atol=OBS_ATOL)
        assert (terminated, truncated) == (step["terminated"], step["truncated"])
        assert reward == pytest.approx(step["reward"], rel=0, abs=STEP_ATOL)
        pure = info["pure_components"]
        assert pure["degradation"] == pytest.approx(step["pure"]["r_deg"], rel=0, abs=STEP_ATOL)
        assert pure["trading"] == pytest.approx(step["pure"]["r_trad"], rel=RTOL)
        assert pure["clipping"] == pytest.approx(step["pure"]["r_clip"], rel=RTOL)
