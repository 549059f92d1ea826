from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import gym4real  # noqa: F401  (registers the ids)
from gym4real.core.testing import compare_vector_with_sync
from gym4real.dam import DamEnv
from gym4real.dam.lake import np_sum
from gym4real.dam.vector import DamVectorEnv, pairwise_column_sums

NEEDS_NUMBA = pytest.mark.skipif(importlib.util.find_spec("numba") is None, reason="numba (extra fast) not installed")


def _close(actual: Any, expected: Any) -> None:
    """Equal up to rounding: numpy's vectorised power (and x * x for x ** 2) may differ in the last bit."""
    np.testing.assert_allclose(actual, expected, rtol=1e-12, atol=1e-9)


def _compare_step(out: tuple[Any, ...], single: list[tuple[Any, ...]]) -> None:
    obs, rewards, terminated, truncated, info = out
    np.testing.assert_allclose(obs, np.stack([o[0] for o in single]), rtol=1e-6, atol=1e-6)  # float32 level
    _close(rewards, [o[1] for o in single])
    np.testing.assert_array_equal(terminated, [o[2] for o in single])
    np.testing.assert_array_equal(truncated, [o[3] for o in single])
    for key in ("level", "release", "year", "cost"):
        _close(info[key], [o[4][key] for o in single])
    for name, values in info["reward_components"].items():
        if name.startswith("_"):  # Gymnasium's mask of which copies report the component
            assert values.all()
            continue
        _close(values, [o[4]["reward_components"][name] for o in single])
    if truncated.any():
        _close(info["recorded_level_rmse"], [o[4]["recorded_level_rmse"] for o in single])


@pytest.mark.parametrize("preset", ["default", "test"])  # random years, and the test years in turn
def test_batched_copies_follow_the_single_env_step_by_step(preset: str) -> None:
    n = 5
    vec = gym.make_vec("gym4real/dam-v0", num_envs=n, vectorization_mode="vector_entry_point", preset=preset)
    singles = [DamEnv(preset=preset) for _ in range(n)]
    obs, info = vec.reset(seed=21)
    starts = [e.reset(seed=21 + i) for i, e in enumerate(singles)]
    np.testing.assert_array_equal(obs, np.stack([o for o, _ in starts]))
    np.testing.assert_array_equal(info["year"], [i["year"] for _, i in starts])
    rng = np.random.default_rng(1)
    horizon = singles[0].config.sim_horizon
    for t in range(horizon + 40):  # a year, then the next episode
        actions = rng.uniform(-50.0, 550.0, size=(n, 1)).astype(np.float32)  # some outside the box: clipped
        out = vec.step(actions)
        assert vec.observation_space.contains(out[0])
        if t == horizon:  # next-step autoreset: each copy continues as the single env without a seed
            starts = [e.reset() for e in singles]
            np.testing.assert_array_equal(out[0], np.stack([o for o, _ in starts]))
            np.testing.assert_array_equal(out[4]["year"], [i["year"] for _, i in starts])
            assert not out[1].any() and not out[3].any()
            continue
        _compare_step(out, [e.step(a) for e, a in zip(singles, actions, strict=True)])
        assert out[3].all() == (t == horizon - 1)


def test_reset_options_per_copy_match_the_single_env() -> None:
    years, levels = [1950, 1996, 1970], [0.0, 0.35, 1.0]
    vec = DamVectorEnv(3, preset="test")
    singles = [DamEnv(preset="test") for _ in years]
    vec.reset(options={"year": years, "init_level": levels})
    for e, year, level in zip(singles, years, levels, strict=True):
        e.reset(options={"year": year, "init_level": level})
    for day in range(30):
        actions = np.full((3, 1), 100.0 + 10 * day, dtype=np.float32)
        _compare_step(vec.step(actions), [e.step(a) for e, a in zip(singles, actions, strict=True)])
    # without a seed, a cycle of years starts copy i at year i (13 copies: the 13 test years)
    _, info = DamVectorEnv(13, preset="test").reset()
    assert info["year"].tolist() == list(singles[0].years)


def test_an_evaporating_lake_below_l_min_matches_the_single_env(tmp_path: Path) -> None:
    rates = tmp_path / "evaporation.csv"
    rates.write_text("rate_mm_per_day\n" + "\n".join(["100.0"] * 365) + "\n")  # 169 m3/s: it drains
    kwargs: dict[str, Any] = {
        "preset": "test",
        "lake": {"evaporation": True, "evaporation_rates": str(rates)},
        "level_bounds": (-40, 6),
    }
    vec = DamVectorEnv(4, **kwargs)
    singles = [DamEnv(**kwargs) for _ in range(4)]
    vec.reset(seed=5, options={"init_level": -0.45})
    for i, e in enumerate(singles):
        e.reset(seed=5 + i, options={"init_level": -0.45})
    rng = np.random.default_rng(2)
    for _ in range(90):
        actions = rng.uniform(0.0, 491.0, size=(4, 1)).astype(np.float32)
        _compare_step(vec.step(actions), [e.step(a) for e, a in zip(singles, actions, strict=True)])
    assert (vec.level < singles[0].config.lake.min_level).all()  # the dry-lake branch was taken


def test_bad_actions_are_refused_like_the_single_env() -> None:
    vec = DamVectorEnv(3, preset="test")
    vec.reset(seed=0)
    level = vec.level
    with pytest.raises(ValueError, match=r"shape \(3, 2\), not \(3, 1\)"):
        vec.step(np.zeros((3, 2), dtype=np.float32))
    with pytest.raises(ValueError, match=r"shape \(4, 1\), not \(3, 1\)"):
        vec.step(np.zeros((4, 1), dtype=np.float32))
    with pytest.raises(ValueError, match="it holds text, not numbers"):
        vec.step(["a", "b", "c"])
    with pytest.raises(ValueError, match=r"\(copies \[1\]\) .*NaN"):
        vec.step(np.array([[1.0], [np.nan], [2.0]]))
    strict = DamVectorEnv(3, preset="test", invalid_action="raise")
    strict.reset(seed=0)
    with pytest.raises(ValueError, match="not in the action space"):
        strict.step(np.array([[1.0], [600.0], [2.0]]))
    with pytest.raises(ValueError, match="not in the action space"):
        DamEnv(preset="test", invalid_action="raise").step(np.array([600.0]))  # as the single env
    np.testing.assert_array_equal(vec.level, level)  # the refused steps changed nothing
    _, rewards, *_ = vec.step(np.array([100.0, 200.0, 300.0]))  # shape (num_envs,) is fine
    assert rewards.shape == (3,)


def test_unsupported_modes_and_bad_options_are_refused() -> None:
    with pytest.raises(ValueError, match="corrected"):
        DamVectorEnv(2, fidelity="upstream")
    with pytest.raises(ValueError, match="np_random_years"):
        DamVectorEnv(2, fixes={"np_random_years": False})
    vec = DamVectorEnv(2, preset="test")
    with pytest.raises(ValueError, match="unknown reset options"):
        vec.reset(options={"day": 3})
    with pytest.raises(ValueError, match="not years of this env"):
        vec.reset(options={"year": [1950, 1951]})
    with pytest.raises(ValueError, match="\\['soon'\\] are not years"):
        vec.reset(options={"year": "soon"})
    with pytest.raises(ValueError, match="one per copy"):
        vec.reset(options={"year": [1950, 1970, 1996]})
    with pytest.raises(ValueError, match="init_level"):
        vec.reset(options={"init_level": 50.0})


@pytest.mark.parametrize("rows", [1, 5, 8, 24, 100, 300])
def test_column_sums_follow_numpys_pairwise_order(rows: int) -> None:
    values = np.random.default_rng(rows).uniform(0, 500, size=(rows, 64))
    expected = [np_sum(values[:, j].tolist()) for j in range(64)]
    np.testing.assert_array_equal(pairwise_column_sums(values), expected)
    np.testing.assert_array_equal(pairwise_column_sums(values), values.T.copy().sum(axis=1))


@pytest.mark.parametrize(
    ("kwargs", "num_envs", "steps"),
    [
        ({"preset": "test"}, 3, 740),
        ({"max_episode_steps": 30}, 3, 100),
    ],
)
@pytest.mark.parametrize("compiled", [pytest.param(True, marks=NEEDS_NUMBA), False])
def test_native_vector_env_is_a_drop_in_for_sync_vector_env(
    kwargs: dict[str, Any], num_envs: int, steps: int, compiled: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Same seeds and actions give the trajectories of ``SyncVectorEnv`` of the single env, across autoresets,
    with the compiled day (numba) and with the numpy one (what runs without numba).

    Both bit for bit: each sub-step's expressions in the single env's order, with libm's ``pow`` (NumPy's
    vectorised ``power`` differs from it in the last bit of about one value in twenty).
    """
    made = []
    original = DamVectorEnv.__init__

    def init(self: DamVectorEnv, *args: Any, **kw: Any) -> None:
        original(self, *args, compiled=compiled, **kw)
        made.append(self)

    monkeypatch.setattr(DamVectorEnv, "__init__", init)
    rtol = 0.0
    result = compare_vector_with_sync("gym4real/dam-v0", num_envs, steps, seed=3, rtol=rtol, **kwargs)
    assert (result.episode_ends >= 2).all()
    assert [vec._kernel is not None for vec in made] == [compiled]
