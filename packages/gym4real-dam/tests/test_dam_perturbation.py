from __future__ import annotations

import math
import pickle
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import gym4real  # noqa: F401  (registers the ids)
from gym4real.dam import DamEnv
from gym4real.dam.lake import SECONDS_PER_DAY

YEAR = 1950
FEASIBLE = np.array([50.0], dtype=np.float32)  # in 1950 stays inside [q_min, q_max] = [MEF 5, q_max(h)]


def _trajectory(env: DamEnv, seed: int, actions: np.ndarray) -> list[tuple[object, ...]]:
    obs, info = env.reset(seed=seed, options={"year": YEAR})
    out: list[tuple[object, ...]] = [(obs.tobytes(), info["storage"])]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        out.append((obs.tobytes(), reward, terminated, truncated, info["level"], info["reward_components"]))
    return out


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
@pytest.mark.parametrize("nominal", [{}, {"lake_surface": 1.0, "inflow": 1.0}])
def test_nominal_scales_restore_the_nominal_trajectory_exactly(fidelity: str, nominal: dict[str, float]) -> None:
    actions = np.random.default_rng(0).uniform(0, 491.61, size=(365, 1)).astype(np.float32)
    env, reference = DamEnv(preset="test", fidelity=fidelity), DamEnv(preset="test", fidelity=fidelity)
    env.perturb({"lake_surface": 1.2, "inflow": 0.85})
    perturbed = _trajectory(env, 3, actions[:30])
    assert perturbed != _trajectory(reference, 3, actions[:30])
    env.perturb(nominal)
    assert _trajectory(env, 3, actions) == _trajectory(reference, 3, actions)
    assert env.lake.surface == reference.lake.surface and env.episode == reference.episode


@pytest.mark.parametrize("scale", [0.8, 1.25])
def test_level_change_per_substep_is_divided_by_the_surface_scale(scale: float) -> None:
    env, nominal = DamEnv(preset="test"), DamEnv(preset="test")
    env.perturb({"lake_surface": scale})
    env.reset(options={"year": YEAR})
    nominal.reset(options={"year": YEAR})
    assert env.lake.surface == pytest.approx(scale * nominal.lake.surface, rel=1e-15)
    for t in range(60):
        days = []
        for e in (env, nominal):
            ep = e.episode
            trace = e.lake.trace(e.storage, float(FEASIBLE[0]), ep.inflow[t], ep.min_flow[t], ep.evaporation[t])
            levels = [e.lake.storage_to_level(s) for s, _ in trace]
            assert all(r == FEASIBLE[0] for _, r in trace[:-1])  # the release stays inside [q_min, q_max]
            days.append((np.diff(levels), e.level, e.step(FEASIBLE)[-1]))
        (dh, start, info), (dh_nominal, start_nominal, info_nominal) = days
        np.testing.assert_allclose(dh, dh_nominal / scale, rtol=1e-9, atol=0)
        # the env's day is the same integration: dh = dt (inflow - release) / (s A)
        assert info["release"] == info_nominal["release"] == FEASIBLE[0]
        assert info["level"] - start == pytest.approx((info_nominal["level"] - start_nominal) / scale, rel=1e-9)


def test_evaporated_depth_does_not_depend_on_the_surface(tmp_path: Path) -> None:
    rates = tmp_path / "evaporation.csv"
    rates.write_text("rate_mm_per_day\n" + "\n".join(["2.0"] * 365) + "\n")
    kwargs = {"lake": {"evaporation": True, "evaporation_rates": str(rates)}, "level_bounds": (-2, 6)}
    env, nominal = DamEnv(preset="test", **kwargs), DamEnv(preset="test", **kwargs)  # type: ignore[arg-type]
    env.perturb({"lake_surface": 1.3})
    env.reset(options={"year": YEAR})
    nominal.reset(options={"year": YEAR})
    assert env.episode.evaporation[0] == pytest.approx(1.3 * nominal.episode.evaporation[0], rel=1e-15)
    for _ in range(10):
        start = env.level
        *_, info = env.step(FEASIBLE)
        # mass balance of the larger lake: s A dh = 86400 (inflow - release - rate * s A)
        volume = SECONDS_PER_DAY * (info["inflow"] - info["release"]) - 2.0e-3 * env.lake.surface
        assert env.lake.surface * (info["level"] - start) == pytest.approx(volume, rel=1e-9)


def test_inflow_scale_enters_the_mass_balance() -> None:
    env, nominal = DamEnv(preset="test"), DamEnv(preset="test")
    env.perturb({"inflow": 1.15})
    env.reset(options={"year": YEAR})
    nominal.reset(options={"year": YEAR})
    area = env.lake.surface
    for _ in range(30):
        start, start_nominal = env.level, nominal.level
        *_, info = env.step(FEASIBLE)
        *_, info_nominal = nominal.step(FEASIBLE)
        assert info["inflow"] == pytest.approx(1.15 * info_nominal["inflow"], rel=1e-15)
        assert info["release"] == info_nominal["release"] == FEASIBLE[0]
        extra = SECONDS_PER_DAY * 0.15 * info_nominal["inflow"] / area  # the extra inflow's level rise
        dh, dh_nominal = info["level"] - start, info_nominal["level"] - start_nominal
        assert dh - dh_nominal == pytest.approx(extra, rel=1e-6)


def test_scales_multiply_the_nominal_values_from_the_next_reset() -> None:
    env, nominal = DamEnv(preset="test"), DamEnv(preset="test")
    nominal.reset(options={"year": YEAR})
    env.reset(options={"year": YEAR})
    env.perturb({"inflow": 1.1})
    assert env.episode.inflow == nominal.episode.inflow  # not before the reset
    env.perturb({"inflow": 1.1})
    for _ in range(2):  # no compounding; persists over resets
        env.reset(options={"year": YEAR})
        assert env.episode.inflow[0] == pytest.approx(1.1 * nominal.episode.inflow[0], rel=1e-15)
        assert env.scales == {"lake_surface": 1.0, "inflow": 1.1}
    env.perturb({"lake_surface": 0.9})  # replaces the previous scales: inflow back to nominal
    env.reset(options={"year": YEAR})
    assert env.episode.inflow == nominal.episode.inflow
    assert env.lake.surface == pytest.approx(0.9 * nominal.lake.surface, rel=1e-15)


@pytest.mark.parametrize(
    ("scales", "message"),
    [
        ({"surface": 1.1}, "unknown perturbation parameters \\['surface'\\]"),
        ({"inflow": 0.0}, "`inflow` must be a finite number > 0"),
        ({"lake_surface": -1.0}, "`lake_surface` must be a finite number > 0"),
        ({"inflow": math.nan}, "finite number > 0"),
        ({"inflow": math.inf}, "finite number > 0"),
        ({"inflow": "much"}, "finite number > 0"),
        ({"lake_surface": 0.05}, "level_bounds"),  # a tiny lake could leave the observation box
        ({"inflow": 3.0}, "level_bounds"),
    ],
)
def test_bad_perturbations_are_refused(scales: dict[str, object], message: str) -> None:
    env = DamEnv(preset="test")
    env.perturb({"inflow": 1.05})
    with pytest.raises(ValueError, match=message):
        env.perturb(scales)  # type: ignore[arg-type]
    env.reset()
    assert env.scales == {"lake_surface": 1.0, "inflow": 1.05}  # the refused call changed nothing


def test_perturbed_env_pickles_and_passes_check_env() -> None:
    env = DamEnv(preset="test")
    env.perturb({"lake_surface": 1.1, "inflow": 0.9})
    env.reset(options={"year": YEAR})
    clone = pickle.loads(pickle.dumps(env))
    assert clone.scales == env.scales
    np.testing.assert_array_equal(clone.step(FEASIBLE)[0], env.step(FEASIBLE)[0])
    check_env(env, skip_render_check=True)


def test_wrapper_draws_the_scales_the_env_applies() -> None:
    from gym4real.wrappers import ExogenousPerturbation

    env = ExogenousPerturbation(gym.make("gym4real/dam-v0"), 0.1)
    _, info = env.reset(seed=4)
    assert info["perturbation"] == env.unwrapped.scales  # type: ignore[attr-defined]
