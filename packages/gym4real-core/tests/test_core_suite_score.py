"""The suite score's scale and stratified bootstrap, and the comparison statistics it reports (issue 24)."""

from __future__ import annotations

import itertools
from collections import Counter

import numpy as np
import pytest
from scipy import stats as sps

from gym4real.bench import stats, suite_score

#: A scale that leaves scores as they are (0 -> 0, 1 -> 1), for tests of the aggregate alone.
IDENTITY = suite_score.Scale("e", 0.0, "one", 1.0)


def _within_exact_interval(values: list[float], low: float, high: float) -> bool:
    """Whether ``low`` and ``high`` are the 2.5 and 97.5 percentiles of equally likely ``values``, up to the
    sampling error of the bootstrap's replicates (one percentile point either way)."""
    lows, highs = (np.percentile(values, q, method="inverted_cdf") for q in ([1.5, 3.5], [96.5, 98.5]))
    return bool(lows[0] <= low <= lows[1] and highs[0] <= high <= highs[1])


def test_stratified_two_level_bootstrap_matches_brute_force_enumeration() -> None:
    # env a: 2 seeds x 2 test episodes; env b: 1 seed x 3 test episodes
    a, b = np.array([[0.1, 0.9], [0.4, 0.2]]), np.array([[0.3, 0.5, 2.0]])
    runs = {"a": (a, IDENTITY), "b": (b, IDENTITY)}
    exact: Counter[float] = Counter()
    pooled: list[float] = []
    # every replicate, each equally likely: a's seeds and a's episodes (one draw for both seeds), b's episodes
    for rows in itertools.product(range(2), repeat=2):
        for cols in itertools.product(range(2), repeat=2):
            run_a = [sps.trim_mean(a[r, list(cols)], 0.25) for r in rows]
            for cols_b in itertools.product(range(3), repeat=3):
                value = float(sps.trim_mean([*run_a, sps.trim_mean(b[0, list(cols_b)], 0.25)], 0.25))
                exact[round(value, 12)] += 1
                pooled.append(value)
    total = sum(exact.values())
    assert total == 2**2 * 2**2 * 3**3
    reps = 100_000
    replicates = suite_score.stratified_replicates(runs, reps=reps, seed=1)
    assert replicates.shape == (reps, 3)
    drawn = Counter(np.round(suite_score.iqm_of_rows(replicates), 12).tolist())
    assert set(drawn) <= set(exact)
    for value, count in exact.items():
        assert drawn[value] / reps == pytest.approx(count / total, abs=0.006)
    point, ci_low, ci_high = suite_score.aggregate(runs, suite_score.iqm_of_rows)
    runs_of_a = sps.trim_mean(a, 0.25, axis=1)
    assert point == pytest.approx(sps.trim_mean([*runs_of_a, sps.trim_mean(b[0], 0.25)], 0.25))
    assert _within_exact_interval(pooled, ci_low, ci_high), (ci_low, ci_high, np.percentile(pooled, [2.5, 97.5]))


def test_a_deterministic_agent_gets_the_width_of_its_test_episodes() -> None:
    episodes = np.array([0.2, 0.6, 1.4])
    same = np.tile(episodes, (3, 1))  # three seeds, one policy: the seeds do not differ
    values = [float(sps.trim_mean(episodes[list(c)], 0.25)) for c in itertools.product(range(3), repeat=3)]
    point, ci_low, ci_high = suite_score.aggregate({"e": (same, IDENTITY)}, suite_score.iqm_of_rows)
    assert ci_high - ci_low > 0.5  # not the zero width of resampling seeds alone
    assert _within_exact_interval(values, ci_low, ci_high), (ci_low, ci_high, np.percentile(values, [2.5, 97.5]))
    assert ci_low <= point <= ci_high


def test_the_aggregate_normalises_each_run_with_its_envs_scale() -> None:
    cost = suite_score.Scale("cost", -400.0, "good", -100.0)
    runs = {"cost": (np.array([[-100.0, -100.0], [-400.0, -400.0]]), cost)}
    assert suite_score.pooled(runs).tolist() == [1.0, 0.0]
    assert suite_score.summary(runs)["runs"] == 2


def _episodes(*values: float) -> np.ndarray:
    return np.array([values])


def test_the_scale_puts_random_at_zero_and_the_best_rule_at_one() -> None:
    rng = np.random.default_rng(0)
    noise = rng.normal(0, 5, size=(1, 40))
    baselines = {"random": -400 + noise, "worse": -900 + noise, "good": -100 + noise, "oracle": 0 + noise}
    scale = suite_score.scale("e", baselines, ("worse", "good"))  # a cost objective
    assert scale.usable and scale.separated and scale.best == "good"  # the oracle is no rule
    assert scale.normalise(stats.iqm(baselines["random"])) == 0.0
    assert scale.normalise(stats.iqm(baselines["good"])) == 1.0
    assert scale.normalise(scale.random - 500) < 0  # a rule worse than random is negative, not an anchor
    assert scale.record() == {
        "zero": "random",
        "one": "good",
        "separated": True,
        "difference": [pytest.approx(300.0), pytest.approx(300.0)],  # the same noise on every episode: paired
    }


@pytest.mark.parametrize(
    ("baselines", "rule_based", "note"),
    [
        ({"random": _episodes(1.0, 2.0), "flat": _episodes(1.0, 2.0)}, ("flat",), "no rule-based baseline beats"),
        ({"random": _episodes(5.0, 6.0), "flat": _episodes(1.0, 2.0)}, ("flat",), "no rule-based baseline beats"),
        ({"random": _episodes(1.0), "oracle": _episodes(9.0)}, (), "no rule-based baseline (the 1"),
        ({"fixed": _episodes(1.0)}, ("fixed",), "no `random` baseline"),
    ],
)
def test_an_env_without_a_scale_says_why(
    baselines: dict[str, np.ndarray], rule_based: tuple[str, ...], note: str
) -> None:
    scale = suite_score.scale("e", baselines, rule_based)
    assert not scale.usable and not scale.separated and scale.note.startswith(note)


def test_anchors_within_the_noise_of_the_test_episodes_give_no_scale() -> None:
    # the rule is ahead (IQM difference 1) but far behind on some episodes: the bootstrap interval includes 0
    random = _episodes(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    rule = _episodes(-9.0, 9.0, -8.0, 10.0, 1.0, 1.0, 1.0, 1.0)
    scale = suite_score.scale("e", {"random": random, "rule": rule}, ("rule",))
    estimate, low, high = stats.difference_ci(rule, random, False, False)
    assert estimate > 0 and low < 0 < high
    assert not scale.usable and scale.best == "rule"
    assert scale.record() == {"zero": "random", "one": "rule", "separated": False, "difference": [low, high]}
    assert f"{estimate:,.4g} [{low:,.4g}, {high:,.4g}]" in scale.note  # the measured difference is the reason
    # the same rule, ahead on every episode by the same amount, separates its anchors
    assert suite_score.scale("e", {"random": random, "rule": random + 1.25}, ("rule",)).separated


def test_a_run_identical_to_an_anchor_scores_it_exactly() -> None:
    rng = np.random.default_rng(0)
    random, best = rng.normal(-50, 9, size=(1, 30)), rng.normal(-10, 3, size=(1, 30))
    scale = suite_score.scale("e", {"random": random, "rule": best}, ("rule",))
    assert suite_score.run_scores(best, scale).tolist() == [1.0]
    assert suite_score.run_scores(random, scale).tolist() == [0.0]


def test_the_shortfall_below_the_best_rule_is_the_mean_shortfall_below_one() -> None:
    runs = np.array([[0.5, 1.5, 0.0, 1.0]])
    assert suite_score.shortfall_of_rows(runs).tolist() == [(0.5 + 0 + 1 + 0) / 4]


def test_suite_profile_counts_runs_above_each_threshold() -> None:
    runs = {"a": (np.array([[0.0, 0.0], [1.0, 1.0]]), IDENTITY), "b": (np.array([[2.0, 2.0]]), IDENTITY)}
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
