"""Exogenous perturbation of MicrogridEnv: battery capacity, prices, demand and PV scaled from nominal."""

from __future__ import annotations

import math
import pickle
from typing import Any

import numpy as np
import pytest

from gym4real.microgrid import MicrogridEnv

ALL_NAMES = ("battery_capacity", "energy_price", "demand", "generation")


def _run(env: MicrogridEnv, seed: int, actions: np.ndarray) -> list[tuple[Any, ...]]:
    obs, info = env.reset(seed=seed)
    out: list[tuple[Any, ...]] = [(obs, info["profile"], info["start"], info["soc"], info["soh"])]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(np.array([a], np.float32))
        out.append((obs, reward, terminated, truncated, info["reward_components"], info["battery"]))
    return out


def _assert_same(a: list[tuple[Any, ...]], b: list[tuple[Any, ...]]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x[0], y[0])
        assert x[1:] == y[1:]


def _surplus_hour(env: MicrogridEnv, profile: str) -> int:
    """A row whose PV surplus the battery can take whole in an hour from the initial SoC."""
    demand = env.world.profile(profile)
    return next(r for r in range(1, 2000) if 500.0 < env.world.pv[r] - demand[r] < 1500.0)


@pytest.mark.parametrize("restore", [{}, dict.fromkeys(ALL_NAMES, 1.0)])
def test_nominal_scales_restore_the_nominal_trajectory_exactly(restore: dict[str, float]) -> None:
    actions = np.random.default_rng(0).uniform(0.0, 1.0, size=60)
    kwargs: dict[str, Any] = {"random_start": True, "random_battery_init": True, "max_steps": 50}
    nominal = _run(MicrogridEnv(**kwargs), 7, actions)
    env = MicrogridEnv(**kwargs)
    env.perturb({"battery_capacity": 1.3, "energy_price": 0.8, "demand": 1.2, "generation": 0.7})
    perturbed = _run(env, 7, actions)
    assert perturbed[1][1] != nominal[1][1]
    env.perturb(restore)
    _assert_same(_run(env, 7, actions), nominal)
    assert env.scales == dict.fromkeys(ALL_NAMES, 1.0)


def test_scales_multiply_the_nominal_values_and_apply_from_the_next_reset() -> None:
    env = MicrogridEnv()
    env.reset(seed=0)
    env.perturb({"battery_capacity": 1.1})
    assert env.battery.capacity == pytest.approx(60.0)  # the running episode keeps its battery
    for _ in range(2):  # no compounding: the same call twice is still 1.1 x nominal
        env.perturb({"battery_capacity": 1.1})
        env.reset(seed=0)
        assert env.battery.capacity == pytest.approx(66.0, rel=1e-12)
        assert env.scales["battery_capacity"] == 1.1
    env.perturb({"energy_price": 2.0})  # replaces the previous scales: capacity back to nominal
    env.reset(seed=0)
    assert env.battery.capacity == pytest.approx(60.0, rel=1e-12)
    assert env._ask[5] == 2.0 * env.world.ask[5]


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
@pytest.mark.parametrize("c", [0.5, 1.25, 3.0])
def test_capacity_scale_divides_the_soc_change_of_a_given_current(c: float, fidelity: str) -> None:
    """Coulomb counting: the same current in the same state moves the SoC by I dt / (3600 c C_nom)."""
    nominal, scaled = MicrogridEnv(preset="test", fidelity=fidelity), MicrogridEnv(preset="test", fidelity=fidelity)
    scaled.perturb({"battery_capacity": c})
    start = _surplus_hour(nominal, "375")
    changes = []
    for env in (nominal, scaled):
        env.reset(options={"profile": "375", "start": start})
        soc0 = env.battery.soc
        _, _, _, _, info = env.step(np.array([1.0], np.float32))
        assert info["battery"]["clipped_power"] == 0.0  # the whole surplus went to the battery
        changes.append((env.battery.soc - soc0, env.battery.current, info["energy"]))
    (d_nom, i_nom, e_nom), (d_scaled, i_scaled, e_scaled) = changes
    assert i_scaled == pytest.approx(i_nom, rel=1e-12)
    assert e_scaled == e_nom
    assert d_scaled == pytest.approx(d_nom / c, rel=1e-9)
    dt, soh = 3600.0, 1.0
    assert d_scaled == pytest.approx(i_scaled * dt / (3600.0 * c * 60.0 * soh), rel=1e-9)


def test_capacity_scale_sets_the_coulomb_counting_of_a_whole_episode() -> None:
    env = MicrogridEnv(preset="test")
    env.perturb({"battery_capacity": 0.6})
    env.reset(seed=2)
    bat = env.battery
    rng = np.random.default_rng(2)
    for _ in range(48):
        soc0, soh0 = bat.soc, bat.soh
        env.step(np.array([rng.uniform()], np.float32))
        assert (bat.soc - soc0) * 0.6 * 60.0 * soh0 == pytest.approx(bat.current, rel=1e-9, abs=1e-9)


def test_price_scale_multiplies_the_trading_term_for_the_same_energy() -> None:
    p = 1.7
    actions = np.random.default_rng(3).uniform(0.0, 1.0, size=80)
    nominal, scaled = MicrogridEnv(), MicrogridEnv()
    scaled.perturb({"energy_price": p})
    obs_n, _ = nominal.reset(seed=4)
    obs_s, _ = scaled.reset(seed=4)
    ask, bid = nominal.feature_names.index("ask"), nominal.feature_names.index("bid")
    for a in actions:
        np.testing.assert_allclose(obs_s[[ask, bid]], p * obs_n[[ask, bid]], rtol=1e-6)
        action = np.array([a], np.float32)
        obs_n, _, _, _, info_n = nominal.step(action)
        obs_s, _, _, _, info_s = scaled.step(action)
        assert info_s["energy"] == info_n["energy"]  # the prices do not move the energy
        comps_n, comps_s = info_n["reward_components"], info_s["reward_components"]
        assert comps_s["trading"] == pytest.approx(p * comps_n["trading"], rel=1e-12, abs=1e-300)
        assert comps_s["degradation"] == comps_n["degradation"]
        assert comps_s["clipping"] == comps_n["clipping"]


@pytest.mark.parametrize(("d", "g"), [(1.3, 1.0), (1.0, 0.6), (0.8, 1.4)])
def test_demand_and_generation_scales_in_the_energy_balance(d: float, g: float) -> None:
    nominal, scaled = MicrogridEnv(preset="test"), MicrogridEnv(preset="test")
    scaled.perturb({"demand": d, "generation": g})
    nominal.reset(options={"profile": "381", "start": 100})
    scaled.reset(options={"profile": "381", "start": 100})
    rng = np.random.default_rng(5)
    for k in range(96):
        a = 0.0 if k < 24 else rng.uniform()
        _, _, _, _, info_n = nominal.step(np.array([a], np.float32))
        obs, _, _, _, info = scaled.step(np.array([a], np.float32))
        e, e_n = info["energy"], info_n["energy"]
        assert e["demand"] == pytest.approx(d * e_n["demand"], rel=1e-12)
        assert e["pv"] == pytest.approx(g * e_n["pv"], rel=1e-12)
        # demand = PV + bought + from battery and surplus = sold + to battery, each hour
        supply = e["pv"] + e["bought"] + e["from_battery"]
        use = e["demand"] + e["sold"] + e["to_battery"]
        assert supply == pytest.approx(use, rel=1e-12, abs=1e-9)
        if a == 0.0:  # the market takes the whole (scaled) net power
            assert e["sold"] - e["bought"] == pytest.approx(g * e_n["pv"] - d * e_n["demand"], rel=1e-9, abs=1e-9)
    assert obs[scaled.feature_names.index("demand")] == np.float32(d * nominal.world.profile("381")[100 + 95])
    assert obs[scaled.feature_names.index("generation")] == np.float32(g * nominal.world.pv[100 + 95])


@pytest.mark.parametrize(
    ("scales", "match"),
    [
        ({"capacity": 1.1}, r"unknown perturbation parameters \['capacity'\].*battery_capacity"),
        ({"battery_capacity": 0.0}, "`battery_capacity` must be a finite number > 0"),
        ({"energy_price": -1.0}, "`energy_price` must be a finite number > 0"),
        ({"demand": math.nan}, "`demand` must be a finite number > 0"),
        ({"generation": math.inf}, "`generation` must be a finite number > 0"),
        ({"demand": "1.1"}, "`demand` must be a finite number > 0"),
        ({"demand": True}, "`demand` must be a finite number > 0"),
    ],
)
def test_bad_perturbations_raise(scales: dict[str, Any], match: str) -> None:
    env = MicrogridEnv()
    env.perturb({"demand": 1.2})
    with pytest.raises(ValueError, match=match):
        env.perturb(scales)
    env.reset(seed=0)
    assert env.scales["demand"] == 1.2  # a refused call leaves the previous scales in place


def test_a_perturbed_env_pickles_with_its_scales() -> None:
    env = MicrogridEnv(max_steps=20)
    env.perturb({"battery_capacity": 1.5, "demand": 0.9})
    env.reset(seed=1)
    copy = pickle.loads(pickle.dumps(env))
    assert copy.scales == env.scales and copy.battery.capacity == env.battery.capacity
    for _ in range(5):
        a = np.array([0.6], np.float32)
        np.testing.assert_array_equal(env.step(a)[0], copy.step(a)[0])
