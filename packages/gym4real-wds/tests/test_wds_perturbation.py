"""Exogenous perturbation of WDSEnv: pump head curves and demand multipliers, scaled per episode."""

from __future__ import annotations

import importlib.metadata
import math
import pickle
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from gym4real.core.datasets import resolve
from gym4real.wds import WDSEnv
from gym4real.wds import engine as en

ANYTOWN = resolve("wds/anytown")
DAY: dict[str, Any] = {"duration": 86_400}  # 24 hourly decisions keep every run short
TANK_AREA = math.pi / 4 * 9.9532**2  # each Anytown tank's cross-section (spec), m²
P79 = " P79             \tR40             \tJ20             \tHEAD H1\t        SPEED 1;"


def run(env: WDSEnv, actions: Sequence[int], profile: int = 3, seed: int = 1) -> list[Any]:
    """Observations, rewards and infos of one episode under a fixed schedule."""
    obs, info = env.reset(seed=seed, options={"profile_index": profile})
    trace: list[Any] = [obs, info["tanks"]]
    for a in actions:
        obs, reward, _, truncated, info = env.step(a)
        trace += [obs, reward, info["volumes"], info["tanks"], info["dsr"]]
        if truncated:
            break
    return trace


def assert_same(x: list[Any], y: list[Any]) -> None:
    assert len(x) == len(y)
    for a, b in zip(x, y, strict=True):
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
        else:
            assert a == b


def head_points(env: WDSEnv) -> list[tuple[float, float]]:
    """The points of the (shared) head curve of Anytown's pumps, as the toolkit holds them now."""
    tk, ph = env._engine.tk, env._engine.ph
    curve = tk.getheadcurveindex(ph, env.network.pump_index[0])
    return [tuple(tk.getcurvevalue(ph, curve, k)) for k in range(1, tk.getcurvelen(ph, curve) + 1)]


def scaled_heads(path: Path, scale: float, text: str | None = None) -> Path:
    """Anytown (or ``text``) with the heads of its pump curve H1 multiplied by ``scale`` in the file itself."""
    lines = []
    for line in (ANYTOWN.read_text() if text is None else text).splitlines():
        fields = line.split()
        if len(fields) == 3 and fields[0] == "H1":
            line = f" H1 {fields[1]} {float(fields[2]) * scale!r}"
        lines.append(line)
    path.write_text("\n".join(lines) + "\n")
    return path


SCHEDULE = [0, 3, 3, 2, 1, 3, 0, 3] * 3


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_unit_scales_and_empty_perturbation_give_the_nominal_trajectory(fidelity: str) -> None:
    nominal = run(WDSEnv(fidelity=fidelity, **DAY), SCHEDULE)
    env = WDSEnv(fidelity=fidelity, **DAY)
    env.perturb({"pump_curve": 1.0, "demand": 1.0})
    assert_same(run(env, SCHEDULE), nominal)
    env.perturb({"pump_curve": 1.3, "demand": 0.7})
    run(env, SCHEDULE)
    env.perturb({})
    assert_same(run(env, SCHEDULE), nominal)


def test_pump_curve_scales_every_head_point_and_equals_the_scaled_network(tmp_path: Path) -> None:
    env = WDSEnv(**DAY)
    nominal_points = head_points(env)
    env.perturb({"pump_curve": 1.1})
    assert head_points(env) == nominal_points  # effective from the next reset only
    perturbed = run(env, SCHEDULE)
    assert head_points(env) == [(x, y * 1.1) for x, y in nominal_points]
    # The law: the perturbed env is the network whose pump curve has every head multiplied by 1.1.
    assert_same(perturbed, run(WDSEnv(network=str(scaled_heads(tmp_path / "h.inp", 1.1)), **DAY), SCHEDULE))


def test_stronger_pumps_deliver_more_and_fill_the_tanks_faster() -> None:
    """Both pumps on for the first hour (before any tank is full), from the same initial levels."""
    pumped, stored = [], []
    for scale in (0.85, 1.0, 1.15):
        env = WDSEnv(**DAY)
        env.perturb({"pump_curve": scale})
        _, start = env.reset(seed=1, options={"profile_index": 3})
        _, _, _, _, info = env.step(3)
        assert max(info["tanks"].values()) < env.network.tank_max_level.min()
        rise = sum(info["tanks"].values()) - sum(start["tanks"].values())
        stored.append(rise * TANK_AREA)
        pumped.append(info["volumes"]["pumped"])
        # water balance of the hour: stored = pumped - delivered
        assert stored[-1] == pytest.approx(pumped[-1] - info["volumes"]["delivered"], rel=1e-3)
    assert 0 < pumped[0] < pumped[1] < pumped[2]
    assert 0 < stored[0] < stored[1] < stored[2]


def test_constant_power_pumps_scale_their_power(tmp_path: Path) -> None:
    text = ANYTOWN.read_text()
    assert P79 in text
    (tmp_path / "p150.inp").write_text(text.replace(P79, " P79 R40 J20 POWER 150"))
    env = WDSEnv(network=str(tmp_path / "p150.inp"), **DAY)
    tk, ph, p79 = env._engine.tk, env._engine.ph, env.network.pump_index[1]
    assert tk.getpumptype(ph, p79) == en.CONST_HP
    power = tk.getlinkvalue(ph, p79, en.PUMP_POWER)
    env.perturb({"pump_curve": 1.2})
    perturbed = run(env, [1, 1, 3, 3])
    assert tk.getlinkvalue(ph, p79, en.PUMP_POWER) == power * 1.2
    # head = power / flow for such a pump: scaling its head is scaling its power (150 -> 180 kW in the
    # file), while P78 keeps the head curve H1, scaled as well.
    scaled = scaled_heads(tmp_path / "p180.inp", 1.2, text.replace(P79, " P79 R40 J20 POWER 180"))
    reference = run(WDSEnv(network=str(scaled), **DAY), [1, 1, 3, 3])
    for a, b in zip(perturbed, reference, strict=True):
        if isinstance(a, dict):
            assert a == pytest.approx(b, rel=1e-6)
        else:
            np.testing.assert_allclose(a, b, rtol=1e-6)


@pytest.mark.parametrize("scale", [0.8, 1.25])
def test_demand_scale_multiplies_the_requested_and_delivered_demand(scale: float) -> None:
    env = WDSEnv(**DAY)
    nominal = run(env, SCHEDULE)
    env.perturb({"demand": scale})
    perturbed = run(env, SCHEDULE)
    full_both = 0
    for k in range(len(SCHEDULE)):
        v0, v1 = nominal[2 + 5 * k + 2], perturbed[2 + 5 * k + 2]
        assert v1["requested"] == pytest.approx(scale * v0["requested"], rel=1e-9)  # base demand x multiplier
        if nominal[2 + 5 * k + 4] == 1.0 and perturbed[2 + 5 * k + 4] == 1.0:  # both deliver in full
            # delivered = requested up to EPANET's pressure-driven demand tolerance
            assert v1["delivered"] == pytest.approx(scale * v0["delivered"], rel=1e-5)
            full_both += 1
    assert full_both >= 5
    # the observation's demand estimate is an average of the (scaled) multipliers
    np.testing.assert_allclose(perturbed[0][-3], scale * nominal[0][-3], rtol=1e-6)


def test_perturbation_never_compounds_and_persists_across_resets() -> None:
    once = WDSEnv(**DAY)
    once.perturb({"pump_curve": 1.1, "demand": 1.05})
    first = run(once, SCHEDULE)
    assert_same(run(once, SCHEDULE), first)  # persists until the next `perturb`
    twice = WDSEnv(**DAY)
    for _ in range(2):
        twice.perturb({"pump_curve": 1.1, "demand": 1.05})
        run(twice, SCHEDULE[:2])
    assert_same(run(twice, SCHEDULE), first)


def test_perturbed_env_pickles_with_its_scales() -> None:
    env = WDSEnv(**DAY)
    env.perturb({"pump_curve": 1.1, "demand": 0.9})
    clone = pickle.loads(pickle.dumps(env))
    assert_same(run(clone, SCHEDULE), run(env, SCHEDULE))


@pytest.mark.parametrize(
    ("scales", "match"),
    [
        ({"pump_curves": 1.1}, r"unknown perturbation parameters \['pump_curves'\].*'pump_curve', 'demand'"),
        ({"demand": 0.0}, "`demand` must be a finite number > 0, not 0.0"),
        ({"demand": -1.0}, "`demand` must be a finite number > 0"),
        ({"pump_curve": math.nan}, "`pump_curve` must be a finite number > 0, not nan"),
        ({"pump_curve": math.inf}, "`pump_curve` must be a finite number > 0"),
        ({"pump_curve": "1.1"}, "`pump_curve` must be a finite number > 0"),
        ({"pump_curve": True}, "`pump_curve` must be a finite number > 0"),
    ],
)
def test_bad_perturbations_raise(scales: dict[str, Any], match: str) -> None:
    env = WDSEnv(**DAY)
    env.perturb({"demand": 1.2})
    with pytest.raises(ValueError, match=match):
        env.perturb(scales)
    assert env._scales == {"pump_curve": 1.0, "demand": 1.2}  # a rejected call changes nothing


def test_ctypes_fallback_applies_the_same_perturbation(monkeypatch: pytest.MonkeyPatch) -> None:
    """The epyt backend's ctypes toolkit, run on owa-epanet's library (the same EPANET 2.3.05 build)."""
    owa = pytest.importorskip("epanet.toolkit")
    library = next(Path(owa.__file__).parent.glob("libepanet2.*"), None)
    if library is None:
        pytest.skip("owa-epanet ships no separate EPANET library on this platform")
    monkeypatch.setattr(en, "_BACKENDS", {})
    monkeypatch.setattr(en, "_epyt_library", lambda: library)
    version = importlib.metadata.version
    monkeypatch.setattr(importlib.metadata, "version", lambda name: "0" if name == "epyt" else version(name))
    traces = []
    for engine in ("owa-epanet", "epyt"):
        env = WDSEnv(engine=engine, **DAY)
        assert env.engine_label.startswith(engine)
        env.perturb({"pump_curve": 1.1, "demand": 0.9})
        traces.append(run(env, SCHEDULE))
        env.close()
    assert_same(*traces)
