from __future__ import annotations

import numpy as np
import pytest

from gym4real.bench import stats
from gym4real.core.specs import BaselineSpec, EnvSpec


def test_iqm_is_the_mean_of_the_middle_half() -> None:
    assert stats.iqm([1, 2, 3, 4, 5, 6, 7, 100]) == pytest.approx(np.mean([3, 4, 5, 6]))
    assert stats.iqm([5.0]) == 5.0


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


def test_iqm_is_scipys_trimmed_mean_over_all_runs_and_episodes() -> None:
    scores = np.arange(40.0).reshape(4, 10)
    assert stats.iqm(scores) == pytest.approx(np.mean(np.arange(10.0, 30.0)))


def test_difference_ci_pairs_the_test_episodes() -> None:
    rng = np.random.default_rng(0)
    episodes = rng.normal(0, 10, size=20)  # a spread over episodes that both policies share
    better = episodes + 1.0 + rng.normal(0, 0.05, size=(3, 20))  # three seeds, one unit above everywhere
    diff, low, high = stats.difference_ci(better, episodes[None, :], True, False)
    assert 0 < low <= diff <= high and diff == pytest.approx(1.0, abs=0.1)
    assert high - low < 0.5  # unpaired, the shared spread of 10 would swamp the shift
    assert stats.difference_ci(better, episodes[None, :], True, False) == (diff, low, high)  # seeded
    with pytest.raises(ValueError, match="different test episodes"):
        stats.difference_ci(better, episodes[None, :10], True, False)


def test_iqm_ci_covers_the_iqm_and_narrows_with_more_episodes() -> None:
    rng = np.random.default_rng(1)
    few, many = rng.normal(5, 2, size=(1, 10)), rng.normal(5, 2, size=(1, 400))
    value, low, high = stats.iqm_ci(few, trained=False)
    assert low <= value <= high
    _, low2, high2 = stats.iqm_ci(many, trained=False)
    assert low2 < 5 < high2 and high2 - low2 < high - low


@pytest.mark.parametrize(
    ("relation", "interval", "expected"),
    [
        ("above", (0.5, 2.0), "holds"),
        ("above", (-2.0, -0.5), "refuted"),
        ("above", (-0.5, 2.0), "inconclusive"),
        ("below", (-2.0, -0.5), "holds"),
        ("less_variable", (0.1, 0.3), "refuted"),
        ("not_above", (-0.5, 2.0), "inconclusive"),  # reaches the margin 1: an advantage that matters is possible
        ("not_above", (-0.5, 0.9), "holds"),
        ("not_above", (0.5, 2.0), "refuted"),
    ],
)
def test_verdict_reads_the_interval_of_the_difference(relation: str, interval: tuple, expected: str) -> None:
    margin = 1.0 if relation == "not_above" else None
    assert stats.verdict(relation, *interval, margin=margin)[0] == expected


def test_a_claim_holds_only_when_every_comparison_holds() -> None:
    from gym4real.core.specs import Claim
    from gym4real.results.claims import check_claim

    rng = np.random.default_rng(2)
    base = rng.normal(0, 1, size=(1, 30))
    scores = {"agent": base + 5 + rng.normal(0, 0.1, (2, 30)), "weak": base, "strong": base + 10, "same": base + 5}
    trained = {"agent"}
    assert check_claim(Claim("beats weak", "agent", "above", ("weak",)), scores, trained)["verdict"] == "holds"
    both = check_claim(Claim("beats both", "agent", "above", ("weak", "strong")), scores, trained)
    assert both["verdict"] == "refuted" and both["deciding"] == "strong"
    tie = check_claim(Claim("beats same", "agent", "above", ("same",)), scores, trained)
    assert tie["verdict"] == "inconclusive" and tie["comparisons"][0]["low"] < 0 < tie["comparisons"][0]["high"]
    assert check_claim(Claim("x", "agent", "above", ("missing",)), scores, trained)["verdict"] == "not checked"
    steady = {"agent": base * 0.1, "other": base}
    assert check_claim(Claim("less spread", "agent", "less_variable", ("other",)), steady, set())["verdict"] == "holds"


def test_claims_are_checked_records() -> None:
    from gym4real.core.specs import Claim

    with pytest.raises(ValueError, match="relation"):
        Claim("t", "ppo", "beats", ("random",))
    with pytest.raises(ValueError, match="no other policy"):
        Claim("t", "ppo", "above", ())


def test_t_band_is_the_student_interval_of_the_seed_mean_and_none_where_one_seed_is_left() -> None:
    import warnings

    from scipy import stats as sps

    rows = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, np.nan], [4.0, 3.0, np.nan]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # curves of unequal length warned (SmallSampleWarning) on every run
        mean, low, high = stats.t_band(rows)
    half = sps.t.ppf(0.975, 2) * sps.sem(rows[:, :2], axis=0)
    np.testing.assert_allclose(mean, [7 / 3, 3.0, 3.0])
    np.testing.assert_allclose(high[:2] - mean[:2], half)
    np.testing.assert_allclose(mean[:2] - low[:2], half)
    assert mean[2] == 3.0 and np.isnan(low[2]) and np.isnan(high[2])  # no band from one seed


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"causal": False}, "declare `bound`"),
        ({"causal": False, "bound": "optimal", "bound_note": "n"}, "declare `bound`"),
        ({"causal": False, "bound": "exact"}, "`bound_note`"),
        ({"causal": False, "bound": "heuristic", "bound_note": "n"}, "needs `gap`"),
        ({"causal": False, "bound": "heuristic", "gap": float("nan"), "bound_note": "n"}, "needs `gap`"),
        ({"causal": False, "bound": "heuristic", "gap": -0.1, "bound_note": "n"}, "needs `gap`"),
        ({"causal": False, "bound": "exact", "gap": 0.01, "bound_note": "n"}, "for a `heuristic` bound only"),
        ({"bound": "exact", "bound_note": "n"}, "is causal"),
    ],
)
def test_an_upper_reference_declares_its_kind_of_bound(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        BaselineSpec("gym4real/demo-v0", "hindsight", "m:f", **kwargs)


def test_the_kinds_of_bound_in_words() -> None:
    heuristic = BaselineSpec(
        "gym4real/demo-v0", "h", "m:f", causal=False, bound="heuristic", gap=0.0004, bound_note="n"
    )
    assert heuristic.is_bound and heuristic.bound_words() == "heuristic (a further search gains <= 0.04 %)"
    oracle = BaselineSpec("gym4real/demo-v0", "o", "m:f", causal=False, bound="not a bound", bound_note="n")
    assert not oracle.is_bound and oracle.bound_words() == "not a bound"


def test_an_interval_takes_more_replicates_the_higher_its_level() -> None:
    """The replicates beyond each end stay :data:`stats.TAIL` however far out the level puts the end."""
    assert stats.replicates_at(0.5) == stats.REPS  # never fewer than REPS
    for level in (0.95, 1 - 0.05 / 4, 1 - 0.05 / 18):
        reps = stats.replicates_at(level)
        assert reps * (1 - level) / 2 == pytest.approx(stats.TAIL, abs=1)
    assert stats.replicates_at(1 - 0.05 / 18) > 10 * stats.replicates_at(0.95)
    with pytest.raises(ValueError, match="level"):
        stats.replicates_at(1.0)


def test_the_sorted_iqm_is_scipys_trimmed_mean() -> None:
    from scipy import stats as sps

    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 4, 7, 150):
        x = rng.normal(size=(50, n))
        assert np.allclose(stats.iqm_last(x), sps.trim_mean(x, 0.25, axis=1), rtol=1e-14, atol=1e-15), n
