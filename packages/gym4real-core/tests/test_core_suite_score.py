"""The suite score's scale and stratified bootstrap, and the comparison statistics it reports (issue 24)."""

from __future__ import annotations

import itertools
from collections import Counter

import numpy as np
import pytest
from scipy import stats as sps

from gym4real.core import stats, suite_score


def test_stratified_bootstrap_matches_brute_force_enumeration() -> None:
    runs = [np.array([0.1, 0.9]), np.array([0.3, 0.5, 2.0])]  # two envs, 2 and 3 seeds
    exact: Counter[float] = Counter()
    for first in itertools.product(runs[0], repeat=2):  # every resample, each equally likely
        for second in itertools.product(runs[1], repeat=3):
            exact[round(float(sps.trim_mean([*first, *second], 0.25)), 12)] += 1
    total = sum(exact.values())
    assert total == 2**2 * 3**3
    replicates = suite_score.stratified_replicates(runs, reps=100_000, seed=1)
    assert set(np.unique(replicates[:, :2])) <= set(runs[0]) and set(np.unique(replicates[:, 2:])) <= set(runs[1])
    drawn = Counter(np.round(suite_score.iqm_of_rows(replicates), 12).tolist())
    assert set(drawn) <= set(exact)
    for value, count in exact.items():
        assert drawn[value] / 100_000 == pytest.approx(count / total, abs=0.006)
    weights = np.array(list(exact.values())) / total
    values = np.array(list(exact))
    order = np.argsort(values)
    cdf = np.cumsum(weights[order])
    low, high = values[order][np.searchsorted(cdf, 0.025)], values[order][np.searchsorted(cdf, 0.975)]
    point, ci_low, ci_high = suite_score.aggregate(runs, suite_score.iqm_of_rows)
    assert point == pytest.approx(sps.trim_mean(np.concatenate(runs), 0.25))
    assert ci_low == pytest.approx(low, abs=0.05) and ci_high == pytest.approx(high, abs=0.05)


def test_the_scale_puts_random_at_zero_and_the_best_rule_at_one() -> None:
    anchors = {"random": -400.0, "worse": -900.0, "good": -100.0, "oracle": 0.0}  # a cost objective
    scale = suite_score.scale("e", anchors, ("worse", "good"))
    assert scale.usable and scale.best == "good"  # the oracle is no rule
    assert scale.normalise(-400.0) == 0.0 and scale.normalise(-100.0) == 1.0
    assert scale.normalise(-900.0) < 0  # a rule worse than random is negative, not an anchor
    assert scale.normalise(0.0) == pytest.approx(4 / 3)  # a perfect cost is a finite score


@pytest.mark.parametrize(
    ("anchors", "rule_based", "note"),
    [
        ({"random": 1.0, "flat": 1.0}, ("flat",), "no rule-based baseline beats `random`"),
        ({"random": 5.0, "flat": 1.0}, ("flat",), "no rule-based baseline beats `random`"),
        ({"random": 1.0, "oracle": 9.0}, (), "no rule-based baseline"),
        ({"fixed": 1.0}, ("fixed",), "no `random` baseline"),
    ],
)
def test_an_env_without_a_scale_says_why(anchors: dict[str, float], rule_based: tuple[str, ...], note: str) -> None:
    scale = suite_score.scale("e", anchors, rule_based)
    assert not scale.usable and scale.note.startswith(note)


def test_a_run_identical_to_an_anchor_scores_it_exactly() -> None:
    rng = np.random.default_rng(0)
    random, best = rng.normal(-50, 9, size=(1, 30)), rng.normal(-10, 3, size=(1, 30))
    scale = suite_score.scale("e", {"random": stats.iqm(random), "rule": stats.iqm(best)}, ("rule",))
    assert suite_score.run_scores(best, scale).tolist() == [1.0]
    assert suite_score.run_scores(random, scale).tolist() == [0.0]


def test_optimality_gap_is_the_mean_shortfall_below_one() -> None:
    runs = np.array([[0.5, 1.5, 0.0, 1.0]])
    assert suite_score.optimality_gap_of_rows(runs).tolist() == [(0.5 + 0 + 1 + 0) / 4]


def test_suite_profile_counts_runs_above_each_threshold() -> None:
    runs = [np.array([0.0, 1.0]), np.array([2.0])]
    profile, low, high = suite_score.suite_profile(runs, np.array([-1.0, 0.5, 1.0, 3.0]))
    assert profile.tolist() == [1.0, 2 / 3, 1 / 3, 0.0]
    assert np.all(low <= profile) and np.all(profile <= high)


def test_an_agent_compared_with_itself_has_probability_of_improvement_one_half() -> None:
    scores = np.random.default_rng(3).normal(size=(3, 12))
    p, low, high = stats.probability_of_improvement(scores, scores, True, True)
    assert p == 0.5 and low < 0.5 < high


def test_probability_of_improvement_is_the_pairwise_count_with_ties_half() -> None:
    a = np.array([[1.0, 5.0], [3.0, 2.0]])  # two seeds, two episodes
    b = np.array([[2.0, 2.0]])  # a baseline
    expected = np.mean([(1 > 2) + (3 > 2), (5 > 2) + 0.5 * (2 == 2)]) / 2
    p, _, _ = stats.probability_of_improvement(a, b, True, False)
    q, _, _ = stats.probability_of_improvement(b, a, False, True)
    assert p == expected and p + q == 1.0


def test_performance_profile_is_the_fraction_strictly_above() -> None:
    assert stats.performance_profile(np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([0.0, 2.0, 4.0])).tolist() == [
        1.0,
        0.5,
        0.0,
    ]
