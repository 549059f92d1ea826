from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest

import gym4real
from gym4real.bench import mo_metrics, stats
from gym4real.bench.upper_reference import PlanCache
from gym4real.core.errors import ConfigError
from gym4real.core.registry import registry
from gym4real.dam.hindsight import DamHindsight, weighted_hindsight

pytest.importorskip("numba")

ENV = "gym4real/dam-v0"
OBJECTIVE = ("deficit", "overflow", "starving")
PAPER = Path(__file__).resolve().parents[3] / "docs" / "results" / "dam-v0-paper" / "episodes.csv"


def _objective(env: gym.Env, actions: list[float] | tuple[float, ...], options: dict) -> float:
    """The protocol's objective of a sequence of releases, stepped through the env."""
    env.reset(options=options)
    total = 0.0
    for a in actions:
        _, _, _, _, info = env.step(np.array([a]))
        total += sum(info["reward_components"][c] for c in OBJECTIVE)
    return total


def _replay(env: gym.Env, policy: DamHindsight, options: dict) -> float:
    obs, _ = env.reset(options=options)
    policy.reset(None)
    total, done = 0.0, False
    while not done:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        total += sum(info["reward_components"][c] for c in OBJECTIVE)
        done = terminated or truncated
    return total


@pytest.mark.parametrize(
    ("year", "init_level"),
    [(1951, -0.40), (1951, 1.20), (1960, 0.35), (2000, -0.44)],  # near starving, near flooding, midway
)
def test_the_plan_is_at_least_the_best_of_a_fine_brute_force_over_three_days(year: int, init_level: float) -> None:
    """Three days from a level where floods or starvation compete with the deficit: every sequence of
    releases on a 25-value grid of the action box (15,625 sequences, stepped through the env)."""
    env = gym.make(ENV, preset="train", sim_horizon=3, year_selection="cycle")
    options = {"year": year, "init_level": init_level}
    grid = np.linspace(0.0, float(env.action_space.high[0]), 25)
    best = max(_objective(env, seq, options) for seq in itertools.product(grid, repeat=3))
    policy = DamHindsight(env, cache=False)
    replayed = _replay(env, policy, options)
    assert replayed >= best - 1e-9 * max(1.0, abs(best))
    assert policy.forward_objectives[-1] == pytest.approx(replayed, rel=1e-12, abs=1e-9)


@pytest.mark.slow
def test_a_further_search_gains_less_than_the_declared_gap_on_the_hardest_test_year() -> None:
    """2010, where the DP's plan was furthest from the best (the local search gains 1.4 %; a random search over the
    DP's releases found 1.05 %, issue 44): transfers up to 30 days apart and changes down to 1/256 of a grid
    quantum, through the env's days, gain less than the gap ``hindsight`` declares (docs/headroom.md)."""
    from gym4real.dam import hindsight_kernel
    from gym4real.dam.hindsight import STEP
    from gym4real.dam.lake import SECONDS_PER_DAY

    env = gym.make(ENV, preset="test")
    env.reset(options={"year": 2010})
    policy = DamHindsight(env, cache=False)
    plan = np.array(policy.plan())
    assert policy.forward_objectives[-1] >= policy.dp_objectives[-1] + 0.01 * abs(policy.dp_objectives[-1])
    c = policy._constants()
    exogenous, (a_low, a_high) = c["exogenous"], c["box"]
    low, high = np.minimum(np.maximum(exogenous[:, 2], a_low), a_high), np.full(len(exogenous), a_high)
    quantum = policy.env.lake.surface * STEP / SECONDS_PER_DAY
    hindsight_kernel.improve(
        plan, c["storage"], exogenous, c["lake"], c["evaporates"], c["substeps"], c["costs"], low, high,
        quantum * 2.0 ** -np.arange(-4, 9), 30, 1e-7,
    )  # fmt: skip
    further = policy._forward(c, [float(d) for d in plan])
    gap = registry().baselines[ENV]["hindsight"].gap
    assert gap is not None and further - policy.forward_objectives[-1] <= gap * abs(policy.forward_objectives[-1])


def test_the_replay_scores_what_the_forward_pass_planned_and_the_estimate_is_close() -> None:
    env = gym.make(ENV, preset="test")
    policy = DamHindsight(env, cache=False)
    replayed = _replay(env, policy, {"year": 1970})
    assert policy.forward_objectives[-1] == pytest.approx(replayed, rel=1e-9)
    # the programme's own estimate interpolates on the grid: close to, not equal to, the replayed score
    assert policy.planned_objectives[-1] == pytest.approx(replayed, rel=0.01)
    # the local search improved the DP's plan; without it the DP's plan is played
    assert policy.forward_objectives[-1] > policy.dp_objectives[-1]
    dp_only = DamHindsight(env, cache=False, search=False)
    assert _replay(env, dp_only, {"year": 1970}) == pytest.approx(policy.dp_objectives[-1], rel=1e-9)
    assert dp_only.forward_objectives == dp_only.dp_objectives


def test_plans_are_cached_by_their_inputs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path))
    env = gym.make(ENV, preset="train", sim_horizon=5, year_selection="cycle")
    first = DamHindsight(env)
    a = _replay(env, first, {"year": 1951})
    files = list((tmp_path / "hindsight").glob("*.json"))
    assert len(files) == 1
    second = DamHindsight(env)
    second._solve = None  # type: ignore[assignment,method-assign]  # a cache miss would call it and fail
    assert _replay(env, second, {"year": 1951}) == a
    with pytest.raises(TypeError):  # another start level is another plan: not in the cache
        _replay(env, second, {"year": 1951, "init_level": 0.5})
    dp_only = DamHindsight(env, search=False)
    dp_only._solve = None  # type: ignore[assignment,method-assign]
    with pytest.raises(TypeError):  # the DP's plan without the search is another plan: not the searched one
        _replay(env, dp_only, {"year": 1951})


def test_hindsight_is_registered_non_causal() -> None:
    info = gym4real.env_info(ENV)
    assert "hindsight" in info.baselines and info.non_causal == ("hindsight",)
    from gym4real.bench.upper_reference import check_protocol

    check_protocol(ENV)


@pytest.mark.slow
def test_hindsight_beats_the_rule_based_baselines_and_the_published_agent_on_the_iqm() -> None:
    """Not exact (a grid), so on the IQM of the 13 test years: at least every rule-based baseline's and
    every published PPO seed's. Plans come from the user cache after the first run (``bench`` fills it)."""
    result = gym4real.benchmark(ENV, ["hindsight"], "test")
    upper = stats.iqm(result.objective_values("hindsight"))
    published = pd.read_csv(PAPER)
    for (policy, seed), rows in published.groupby(["policy", published["seed"].fillna(-1)]):
        assert upper >= stats.iqm(rows.sort_values("episode")["objective"]), (policy, seed)


# -- the weighted planner of gym4real/dam-mo-v0 (the multi-objective upper reference front) -----------------------

MO_ENV = "gym4real/dam-mo-v0"
#: A 1 cm band between the starving and the flood level, from its bottom: releasing keeps the lake from flooding
#: and brings it to starving, holding water back does the reverse, so shortage and flooding compete.
BAND = {"starving_level": 1.20, "flood_level": 1.21}
WEIGHTS = [(1.0, 0.0), (0.0, 1.0), (0.5, 0.5), (0.9, 0.1), (0.2, 0.8), (0.02, 0.98)]


def _vector(env: gym.Env, policy: Any, options: dict, days: int) -> np.ndarray:
    """(shortage, flooding) of a policy or of a sequence of releases, stepped through the vector-reward env."""
    obs, _ = env.reset(options=options)
    if hasattr(policy, "reset"):
        policy.reset(None)
    names = env.unwrapped.components
    total = np.zeros(2)
    for t in range(days):
        obs, reward, _, _, _ = env.step(policy(obs) if callable(policy) else np.array([policy[t]]))
        parts = dict(zip(names, reward, strict=True))
        total += (parts["deficit"] + parts["starving"], parts["overflow"])
    return total


@pytest.mark.parametrize("year", [1951, 2000])
def test_the_weighted_plan_is_at_least_the_best_of_a_fine_brute_force_at_each_weight(year: int) -> None:
    """Three days in a band where shortage and flooding compete (the brute force's front has 4 points on these
    years): at each weight, every sequence of releases on a 25-value grid of the action box, scored by the
    weighted objective, is at most what the weighted planner replays through the vector-reward env."""
    env = gym.make(MO_ENV, preset="train", sim_horizon=3, year_selection="cycle", **BAND)
    options = {"year": year, "init_level": 1.20}
    grid = np.linspace(0.0, float(env.action_space.high[0]), 25)
    brute = np.array([_vector(env, seq, options, 3) for seq in itertools.product(grid, repeat=3)])
    assert len({tuple(v) for v in brute[mo_metrics.nondominated(brute)].round(6)}) >= 2  # a real trade-off
    found: dict[tuple[float, float], np.ndarray] = {}
    for w in WEIGHTS:
        policy = weighted_hindsight(env, weights=w)
        policy._cache = PlanCache(None)
        got = _vector(env, policy, options, 3)
        best = float((brute @ np.array(w)).max())
        assert got @ np.array(w) >= best - 1e-9 * max(1.0, abs(best)), w
        assert policy.forward_objectives[-1] == pytest.approx(got @ np.array(w), rel=1e-12, abs=1e-9)
        found[w] = got
    assert found[(0.0, 1.0)][1] == 0.0 and found[(1.0, 0.0)][0] > brute[:, 0].max()  # beyond the grid's best


def test_the_vector_reward_id_plans_into_the_scalar_ids_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """dam-mo-v0's planner keys its cache on the scalar env it owns: the protocol's plans serve both ids."""
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path))
    scalar, vector = DamHindsight(gym.make(ENV, preset="test")), DamHindsight(gym.make(MO_ENV, preset="test"))
    assert scalar._cache.path is not None and vector._cache.path == scalar._cache.path
    assert ENV.replace("/", "_") in scalar._cache.path.name


def test_weights_are_in_the_plan_cache_key(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Unit weights plan the same days as the protocol's objective, but under another key: neither is taken for
    the other."""
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path))
    env = gym.make(ENV, preset="train", sim_horizon=5, year_selection="cycle")
    plain = DamHindsight(env)
    a = _replay(env, plain, {"year": 1951})
    unit = DamHindsight(env, weights=(1.0, 1.0))
    assert _replay(env, unit, {"year": 1951}) == a  # the same objective: the same plan, planned again
    (cache,) = (tmp_path / "hindsight").glob("*.json")
    assert len(json.loads(cache.read_text())["plans"]) == 2
    for weights in (None, (1.0, 1.0)):
        again = DamHindsight(env, weights=weights)
        again._solve = None  # type: ignore[assignment,method-assign]  # a cache miss would call it and fail
        assert _replay(env, again, {"year": 1951}) == a
    other = DamHindsight(env, weights=(0.5, 0.5))
    other._solve = None  # type: ignore[assignment,method-assign]
    with pytest.raises(TypeError):  # other weights: another plan, not in the cache
        _replay(env, other, {"year": 1951})


def test_the_weighted_planner_refuses_bad_weights() -> None:
    env = gym.make(MO_ENV, preset="train", sim_horizon=3)
    for bad in [(1.0,), (1.0, -0.5), (0.0, 0.0), (float("nan"), 1.0)]:
        with pytest.raises(ConfigError, match="shortage"):
            weighted_hindsight(env, weights=bad)
