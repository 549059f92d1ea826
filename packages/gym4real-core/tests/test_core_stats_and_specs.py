from __future__ import annotations

import numpy as np
import pytest

from gym4real.core import stats
from gym4real.core.specs import BaselineSpec, EnvSpec


def test_iqm_is_the_mean_of_the_middle_half() -> None:
    assert stats.iqm([1, 2, 3, 4, 5, 6, 7, 100]) == pytest.approx(np.mean([3, 4, 5, 6]))
    assert stats.iqm([5.0]) == 5.0


def test_bootstrap_ci_contains_the_mean_and_is_reproducible() -> None:
    x = np.random.default_rng(0).normal(10, 2, size=50)
    lo, hi = stats.bootstrap_ci(x)
    assert lo < x.mean() < hi
    assert (lo, hi) == stats.bootstrap_ci(x)
    assert hi - lo < 2


def test_mean_band_pads_shorter_episodes() -> None:
    mean, low, high = stats.mean_band([np.array([1.0, 2.0, 3.0]), np.array([3.0, 4.0])])
    np.testing.assert_allclose(mean, [2.0, 3.0, 3.0])
    assert np.all(low <= mean) and np.all(mean <= high)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"id": "dam-v0"},
        {"id": "gym4real/Dam-v0"},
        {"entry_point": "no_colon"},
        {"flags": frozenset({"teleportation"})},
    ],
)
def test_env_spec_validation(kwargs) -> None:
    base = {"id": "gym4real/demo-v0", "entry_point": "m:C", "description": "d"}
    with pytest.raises(ValueError):
        EnvSpec(**{**base, **kwargs})


def test_baseline_names_are_snake_case() -> None:
    with pytest.raises(ValueError, match="snake"):
        BaselineSpec("gym4real/demo-v0", "LongestFirst", "m:f")
