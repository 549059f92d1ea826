"""The rgb_array frame shows the microgrid's state: the SoC gauge, flows that balance, running totals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gym4real.core.canvas import GREEN, LIGHT
from gym4real.microgrid import MicrogridEnv
from gym4real.microgrid.rendering import SOC_GAUGE


def test_soc_gauge_fills_to_the_state_of_charge() -> None:
    env = MicrogridEnv(render_mode="rgb_array", preset="test", random_battery_init=True, max_steps=10)
    x0, y0, x1, y1 = SOC_GAUGE
    checked = 0
    for seed in range(40):
        env.reset(seed=seed)
        for _ in range(2):
            soc = env.battery.soc
            if min(abs(soc - 0.2), abs(soc - 1.0)) > 0.03:  # away from the window's marks
                frame = env.render()
                top = y1 - soc * (y1 - y0)
                x = round((x0 + x1) / 2)
                assert tuple(frame[round(top) + 2, x]) == GREEN
                assert tuple(frame[round(top) - 2, x]) == LIGHT
                checked += 1
            env.step(np.array([0.5], dtype=np.float32))
    assert checked > 40


@pytest.mark.parametrize("interval", [1, 3])
def test_drawn_flows_are_the_steps_mean_powers_and_balance(interval: int) -> None:
    env = MicrogridEnv(render_mode="rgb_array", preset="test", decision_interval=interval, max_steps=100)
    env.reset(seed=1)
    rng = np.random.default_rng(1)
    profit = degradation = 0.0
    done = False
    while not done:
        _, _, terminated, truncated, info = env.step(rng.uniform(0, 1, size=1).astype(np.float32))
        done = terminated or truncated
        power = env._renderer.power
        hours = interval if not done else (100 - 1) % interval + 1  # the last step holds what was left
        for k, energy in info["energy"].items():
            assert power[k] == pytest.approx(energy / hours, rel=1e-12)
        supply = power["pv"] + power["bought"] + power["from_battery"]
        assert supply == pytest.approx(power["demand"] + power["sold"] + power["to_battery"], rel=1e-9, abs=1e-6)
        profit += info["pure_components"]["trading"]
        degradation += info["pure_components"]["degradation"]
        assert math.isclose(env._renderer.profit, profit) and math.isclose(env._renderer.degradation, degradation)
    env.reset(seed=2)
    assert env._renderer.profit == 0.0 and env._renderer.power == {}
