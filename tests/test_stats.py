"""The estimators of ``gym4real.core.stats`` against brute-force enumeration, and the claim rules."""

from __future__ import annotations

import itertools
from collections import Counter

import numpy as np
import pytest
from scipy import stats as sps

from gym4real.core import stats
from gym4real.core.rl.claims import check_claim
from gym4real.core.rl.provenance import selected_checkpoint
from gym4real.core.specs import Claim

REPS = 40_000
#: Four standard errors of a frequency estimated from REPS replicates (at most 0.5 / sqrt(REPS)).
TOL = 4 * 0.5 / np.sqrt(REPS)


def _iqm(x: np.ndarray) -> float:
    return float(sps.trim_mean(x, 0.25, axis=None))


def _exact(matrices: list[np.ndarray], trained: list[bool], stat) -> Counter[float]:
    """The exact bootstrap distribution: every seed draw of every trained matrix, every shared episode draw."""
    episodes = matrices[0].shape[1]
    row_draws = [
        list(itertools.product(range(m.shape[0]), repeat=m.shape[0])) if t else [tuple(range(m.shape[0]))]
        for m, t in zip(matrices, trained, strict=True)
    ]
    counts: Counter[float] = Counter()
    for cols in itertools.product(range(episodes), repeat=episodes):
        for rows in itertools.product(*row_draws):
            drawn = [m[np.ix_(r, cols)] for m, r in zip(matrices, rows, strict=True)]
            counts[round(stat(*drawn), 9)] += 1
    total = sum(counts.values())
    return Counter({k: v / total for k, v in counts.items()})


def _frequencies(values: np.ndarray) -> Counter[float]:
    counts = Counter(round(float(v), 9) for v in values)
    return Counter({k: v / len(values) for k, v in counts.items()})


def _same_distribution(sampled: Counter[float], exact: Counter[float]) -> None:
    assert set(sampled) <= set(exact)  # no replicate outside the exact support
    for value, p in exact.items():
        assert abs(sampled[value] - p) <= TOL, (value, sampled[value], p)


def test_the_two_level_bootstrap_of_an_agents_iqm_is_the_enumeration_of_seed_and_episode_draws() -> None:
    scores = np.array([[1.0, 2.0], [10.0, 40.0]])  # 2 seeds x 2 episodes: 4 seed draws x 4 episode draws
    sampled = stats.replicates([scores], [True], stats.batched("iqm"), seed=3, reps=REPS)
    exact = _exact([scores], [True], _iqm)
    _same_distribution(_frequencies(sampled), exact)
    # the episode-only bootstrap (every seed kept) has fewer atoms: resampling the seeds is what widens it
    assert len(exact) > len(_exact([scores], [False], _iqm))


def test_a_baseline_resamples_episodes_only() -> None:
    scores = np.array([[1.0, 5.0, 7.0]])
    sampled = stats.replicates([scores], [False], stats.batched("mean"), seed=1, reps=REPS)
    _same_distribution(_frequencies(sampled), _exact([scores], [False], lambda x: float(x.mean())))


def test_a_difference_takes_the_same_episodes_for_both_policies() -> None:
    agent = np.array([[1.0, 3.0], [2.0, 9.0]])
    baseline = np.array([[0.0, 8.0]])
    stat = stats.batched("iqm")
    sampled = stats.replicates([agent, baseline], [True, False], lambda a, b: stat(a) - stat(b), seed=0, reps=REPS)
    exact = _exact([agent, baseline], [True, False], lambda a, b: _iqm(a) - _iqm(b))
    _same_distribution(_frequencies(sampled), exact)


def test_the_interval_bounds_are_the_exact_distributions_quantiles() -> None:
    scores = np.array([[1.0, 2.0, 4.0], [8.0, 16.0, 32.0]])
    exact = _exact([scores], [True], _iqm)
    _, low, high = stats.iqm_ci(scores, trained=True)
    below = sum(p for v, p in exact.items() if v < low - 1e-9)
    at_or_below = sum(p for v, p in exact.items() if v <= low + 1e-9)
    assert below <= 0.025 + 0.01 and at_or_below >= 0.025 - 0.01
    above = sum(p for v, p in exact.items() if v > high + 1e-9)
    at_or_above = sum(p for v, p in exact.items() if v >= high - 1e-9)
    assert above <= 0.025 + 0.01 and at_or_above >= 0.025 - 0.01


def test_the_interval_is_reproducible_under_its_seed() -> None:
    scores = np.random.default_rng(0).normal(size=(5, 30))
    assert stats.iqm_ci(scores, True, seed=7) == stats.iqm_ci(scores, True, seed=7)
    assert stats.iqm_ci(scores, True, seed=7) != stats.iqm_ci(scores, True, seed=8)


def test_probability_of_improvement_is_the_mann_whitney_average_over_episodes() -> None:
    rng = np.random.default_rng(1)
    a = rng.integers(0, 4, size=(3, 5)).astype(float)  # small integers: many ties
    b = rng.integers(0, 4, size=(2, 5)).astype(float)
    brute = np.mean(
        [
            np.mean(
                [1.0 if a[i, j] > b[k, j] else 0.5 if a[i, j] == b[k, j] else 0.0 for i in range(3) for k in range(2)]
            )
            for j in range(5)
        ]
    )
    p, low, high = stats.probability_of_improvement(a, b, True, True)
    assert p == pytest.approx(brute) and low <= p <= high
    reverse, _, _ = stats.probability_of_improvement(b, a, True, True)
    assert p + reverse == pytest.approx(1.0)


def test_a_policy_is_no_improvement_on_itself() -> None:
    scores = np.random.default_rng(2).normal(size=(4, 12))
    assert stats.probability_of_improvement(scores, scores, False, False) == (0.5, 0.5, 0.5)
    # as two independent trainings, the seeds are drawn apart: the estimate stays 1/2, the interval around it
    p, low, high = stats.probability_of_improvement(scores, scores, True, True)
    assert p == 0.5 and low < 0.5 < high


def test_the_performance_profile_counts_scores_above_each_threshold() -> None:
    scores = np.array([[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]])
    thresholds = [-1.0, 0.0, 2.5, 5.0]
    expected = [sum(v > t for v in scores.ravel()) / 6 for t in thresholds]
    assert stats.performance_profile(scores, thresholds).tolist() == expected
    point, low, high = stats.profile_band(scores, True, thresholds)
    assert point.tolist() == expected and np.all(low <= point) and np.all(point <= high)


def test_float_noise_of_a_difference_is_zero() -> None:
    base = np.full((1, 8), 0.1) * np.arange(1, 9)
    six = np.repeat(base, 6, axis=0)  # a mean of six equal floats is not always that float
    assert stats.difference_ci(six, base, True, False, "spread") == (0.0, 0.0, 0.0)


def test_bad_score_matrices_are_refused_with_the_fix() -> None:
    with pytest.raises(ValueError, match="non-finite"):
        stats.iqm_ci(np.array([[1.0, np.nan]]), True)
    with pytest.raises(ValueError, match="same episodes"):
        stats.difference_ci(np.ones((2, 3)), np.ones((1, 4)), True, False)


@pytest.mark.parametrize(
    ("low", "high", "expected"),
    [
        (-65.9, 168.3, ("inconclusive", "interval reaches the margin and 0")),  # today's trading DQN: was "holds"
        (-5.0, 8.0, ("holds", "interval below the margin")),
        (1.0, 20.0, ("does not hold", "interval above 0")),
    ],
)
def test_a_negative_claim_needs_its_interval_below_the_margin(low: float, high: float, expected: tuple) -> None:
    assert stats.verdict("not_above", low, high, margin=10.0) == expected


def test_a_strict_claim_with_a_zero_interval_does_not_hold() -> None:
    assert stats.verdict("above", 0.0, 0.0)[0] == "does not hold"
    assert stats.verdict("less_variable", 0.0, 0.0)[0] == "does not hold"
    assert stats.verdict("above", -1.0, 2.0) == ("inconclusive", "interval contains 0")
    assert stats.verdict("below", -2.0, -1.0) == ("holds", "interval below 0")


def test_a_policy_identical_to_the_baseline_does_not_reduce_its_variability() -> None:
    baseline = np.random.default_rng(3).normal(0, 300, size=(1, 68))
    scores = {"ppo": np.repeat(baseline, 6, axis=0), "buy_and_hold": baseline}
    claim = Claim("PPO reduces the daily variability", "ppo", "less_variable", ("buy_and_hold",))
    record = check_claim(claim, scores, {"ppo"})
    assert (record["verdict"], record["rule"]) == ("does not hold", "identical in every episode")


def test_consistently_needs_every_seed_above_the_baseline() -> None:
    rng = np.random.default_rng(4)
    good = rng.normal(100, 1, size=(7, 40))
    failed = rng.normal(60, 1, size=(1, 40))  # one seed never learned: IQM 60 against a baseline of 80
    scores = {"q": np.vstack([good, failed]), "base": rng.normal(80, 1, size=(1, 40))}
    plain = check_claim(Claim("Q beats base", "q", "above", ("base",)), scores, {"q"})
    consistent = check_claim(
        Claim("Q consistently beats base", "q", "above", ("base",), consistently=True), scores, {"q"}
    )
    assert plain["verdict"] == "holds"  # the pooled interval hides the failed seed
    assert (consistent["verdict"], consistent["rule"]) == ("does not hold", "every seed")
    assert consistent["comparisons"][0]["seeds"]["seed_iqms"][-1] < 80


def test_a_claim_of_k_comparisons_uses_bonferroni_levels() -> None:
    rng = np.random.default_rng(5)
    scores = {"a": rng.normal(1, 1, size=(3, 20)), **{f"b{i}": rng.normal(0, 1, size=(1, 20)) for i in range(4)}}
    record = check_claim(Claim("A beats all", "a", "above", ("b0", "b1", "b2", "b3")), scores, {"a"})
    assert record["level"] == pytest.approx(1 - 0.05 / 4)
    assert all(c["level"] == record["level"] for c in record["comparisons"])
    one = check_claim(Claim("A beats b0", "a", "above", ("b0",)), scores, {"a"})["comparisons"][0]
    many = record["comparisons"][0]
    assert many["low"] <= one["low"] and many["high"] >= one["high"]  # wider at the family level


def test_claims_declare_what_their_relation_needs() -> None:
    with pytest.raises(ValueError, match="margin"):
        Claim("x does not beat y", "x", "not_above", ("y",))
    with pytest.raises(ValueError, match="margin"):
        Claim("x beats y", "x", "above", ("y",), margin=1.0)
    with pytest.raises(ValueError, match="consistently"):
        Claim("x is steadier", "x", "less_variable", ("y",), consistently=True)


def test_the_selected_checkpoint_is_the_validation_row_the_run_kept() -> None:
    import pandas as pd

    curve = pd.DataFrame({"timesteps": [100, 200, 300, 400], "mean_return": [1.0, 3.0, 3.0, 3.05]})
    assert selected_checkpoint(curve) == (400, 3.05)  # SB3: any strict improvement
    assert selected_checkpoint(curve, min_improvement=0.1) == (200, 3.0)  # tabular: by more than its tolerance


def test_a_claim_against_the_rule_based_strategies_compares_with_exactly_the_protocols_rule_based_ones() -> None:
    from gym4real.core.registry import registry

    about_rules = [
        (env_id, claim)
        for env_id, spec in registry().benchmarks.items()
        for claim in spec.claims
        if "rule-based" in claim.text
    ]
    assert {env_id for env_id, _ in about_rules} >= {"gym4real/dam-v0", "gym4real/elevator-v0", "gym4real/microgrid-v0"}
    for env_id, claim in about_rules:  # `random` follows no rule; each protocol names its rule-based baselines
        assert set(claim.others) == set(registry().benchmarks[env_id].rule_based), (env_id, claim.text)
