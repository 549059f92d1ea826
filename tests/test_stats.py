"""The estimators of ``gym4real.bench.stats`` against brute-force enumeration, and the claim rules."""

from __future__ import annotations

import itertools
from collections import Counter

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from gym4real.bench import stats
from gym4real.core.specs import Claim
from gym4real.results.claims import check_claim
from gym4real.results.provenance import selected_checkpoint

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


def _assert_ends_are_quantiles(exact: dict[float, float], low: float, high: float) -> None:
    """``low`` and ``high`` are the 2.5 % and 97.5 % quantiles of the exact distribution (to 1 % of mass)."""
    below = sum(p for v, p in exact.items() if v < low - 1e-9)
    at_or_below = sum(p for v, p in exact.items() if v <= low + 1e-9)
    assert below <= 0.025 + 0.01 and at_or_below >= 0.025 - 0.01
    above = sum(p for v, p in exact.items() if v > high + 1e-9)
    at_or_above = sum(p for v, p in exact.items() if v >= high - 1e-9)
    assert above <= 0.025 + 0.01 and at_or_above >= 0.025 - 0.01


def test_the_interval_bounds_are_the_exact_distributions_quantiles() -> None:
    scores = np.array([[1.0, 2.0, 4.0], [8.0, 16.0, 32.0]])
    exact = _exact([scores], [True], _iqm)
    _, low, high = stats.iqm_ci(scores, trained=True)
    _assert_ends_are_quantiles(exact, low, high)


def test_two_trained_policies_draw_their_seeds_on_their_own_and_the_episodes_together() -> None:
    """Two trainers' runs (issue 43): each replicate draws each policy's seeds apart, the episodes once for both."""
    a = np.array([[1.0, 3.0], [2.0, 9.0]])
    b = np.array([[0.0, 8.0], [5.0, 4.0]])
    stat = stats.batched("iqm")
    sampled = stats.replicates([a, b], [True, True], lambda x, y: stat(x) - stat(y), seed=0, reps=REPS)
    exact = _exact([a, b], [True, True], lambda x, y: _iqm(x) - _iqm(y))
    _same_distribution(_frequencies(sampled), exact)
    # drawing the same seed indices for both policies would give another distribution
    counts: Counter[float] = Counter()
    for cols in itertools.product(range(2), repeat=2):
        for rows in itertools.product(range(2), repeat=2):
            counts[round(_iqm(a[np.ix_(rows, cols)]) - _iqm(b[np.ix_(rows, cols)]), 9)] += 1
    assert set(counts) != set(exact)


def test_the_difference_of_two_trained_policies_has_the_exact_distributions_quantiles_as_ends() -> None:
    a = np.array([[1.0, 2.0, 4.0], [8.0, 16.0, 32.0]])
    b = np.array([[3.0, 1.0, 7.0], [2.0, 5.0, 11.0], [6.0, 0.5, 9.0]])
    exact = _exact([a, b], [True, True], lambda x, y: _iqm(x) - _iqm(y))
    estimate, low, high = stats.difference_ci(a, b, True, True, "iqm", seed=0, level=0.95)
    assert estimate == pytest.approx(_iqm(a) - _iqm(b))
    _assert_ends_are_quantiles(exact, low, high)


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
        (1.0, 20.0, ("refuted", "interval above 0")),
    ],
)
def test_a_negative_claim_needs_its_interval_below_the_margin(low: float, high: float, expected: tuple) -> None:
    assert stats.verdict("not_above", low, high, margin=10.0) == expected


def test_a_strict_claim_with_a_zero_interval_does_not_hold() -> None:
    assert stats.verdict("above", 0.0, 0.0)[0] == "refuted"
    assert stats.verdict("less_variable", 0.0, 0.0)[0] == "refuted"
    assert stats.verdict("above", -1.0, 2.0) == ("inconclusive", "interval contains 0")
    assert stats.verdict("below", -2.0, -1.0) == ("holds", "interval below 0")


def test_a_policy_identical_to_the_baseline_does_not_reduce_its_variability() -> None:
    baseline = np.random.default_rng(3).normal(0, 300, size=(1, 68))
    scores = {"ppo": np.repeat(baseline, 6, axis=0), "buy_and_hold": baseline}
    claim = Claim("PPO reduces the daily variability", "ppo", "less_variable", ("buy_and_hold",))
    record = check_claim(claim, scores, {"ppo"})
    assert (record["verdict"], record["rule"]) == ("refuted", "identical in every episode")


def test_consistently_is_refuted_by_a_seed_whose_own_interval_is_below() -> None:
    rng = np.random.default_rng(4)
    good = rng.normal(100, 1, size=(7, 40))
    failed = rng.normal(60, 1, size=(1, 40))  # one seed never learned: IQM 60 against a baseline of 80
    scores = {"q": np.vstack([good, failed]), "base": rng.normal(80, 1, size=(1, 40))}
    plain = check_claim(Claim("Q beats base", "q", "above", ("base",)), scores, {"q"})
    consistent = check_claim(
        Claim("Q consistently beats base", "q", "above", ("base",), consistently=True), scores, {"q"}
    )
    assert plain["verdict"] == "holds"  # the pooled interval hides the failed seed
    assert (consistent["verdict"], consistent["rule"]) == ("refuted", "a seed's interval refutes")
    seeds = consistent["comparisons"][0]["seeds"]
    assert [s["verdict"] for s in seeds] == ["holds"] * 7 + ["refuted"] and seeds[-1]["high"] < 0


def _per_seed_exact(a: np.ndarray, b: np.ndarray, b_trained: bool, row: int) -> Counter[float]:
    """The exact distribution of seed ``row``'s difference: its row kept, episodes (and b's seeds) drawn."""
    return _exact([a[row : row + 1], b], [False, b_trained], lambda x, y: _iqm(x) - _iqm(y))


@pytest.mark.parametrize("b_trained", [False, True])
def test_each_seeds_own_interval_is_the_enumeration_of_its_episode_draws(b_trained: bool) -> None:
    a = np.array([[1.0, 4.0, 2.0], [10.0, 0.0, 7.0]])
    b = np.array([[0.0, 3.0, 5.0], [2.0, 2.0, 9.0]]) if b_trained else np.array([[0.0, 3.0, 5.0]])
    iqm, pooled = stats.per_row("iqm"), stats.batched("iqm")
    sampled = stats.replicates([a, b], [False, b_trained], lambda x, y: iqm(x) - pooled(y)[:, None], seed=2, reps=REPS)
    assert sampled.shape == (REPS, 2)
    for row in range(2):
        _same_distribution(_frequencies(sampled[:, row]), _per_seed_exact(a, b, b_trained, row))
    point, low, high = stats.per_seed_difference_ci(a, b, b_trained, "iqm")
    for row in range(2):  # the bounds are the exact distribution's 2.5 % and 97.5 % quantiles
        exact = _per_seed_exact(a, b, b_trained, row)
        assert point[row] == pytest.approx(_iqm(a[row]) - _iqm(b))
        assert sum(p for v, p in exact.items() if v < low[row] - 1e-9) <= 0.025 + 0.01
        assert sum(p for v, p in exact.items() if v <= low[row] + 1e-9) >= 0.025 - 0.01
        assert sum(p for v, p in exact.items() if v > high[row] + 1e-9) <= 0.025 + 0.01
        assert sum(p for v, p in exact.items() if v >= high[row] - 1e-9) >= 0.025 - 0.01


def test_a_seed_below_the_baseline_by_its_point_estimate_alone_leaves_consistently_inconclusive() -> None:
    """Elevator's Q-learning on the published page: 4 of 5 seeds' IQMs below `longest_first`, none by its interval.

    Before verdicts rested on intervals, the claim "did not hold" on those point estimates.
    """
    rng = np.random.default_rng(6)
    base = rng.normal(0, 10, size=(1, 30))
    q = base + np.array([[-1.0], [-0.5], [-0.8], [-0.3], [1.0]]) + rng.normal(0, 3, size=(5, 30))
    seed_iqms, _ = stats.per_seed(q)
    assert np.sum(seed_iqms < stats.iqm(base)) >= 3  # below by the point estimates
    claim = Claim("Q consistently beats base", "q", "above", ("base",), consistently=True)
    record = check_claim(claim, {"q": q, "base": base}, {"q"})
    seeds = record["comparisons"][0]["seeds"]
    assert all(s["low"] < 0 < s["high"] for s in seeds)  # no seed's own interval is below 0
    assert record["verdict"] == "inconclusive"
    assert record["level"] == pytest.approx(1 - 0.05 / (1 * (1 + 5)))  # the pooled and five seeds' intervals


def test_consistently_holds_only_when_every_seeds_own_interval_holds() -> None:
    rng = np.random.default_rng(7)
    base = rng.normal(0, 1, size=(1, 40))
    strong = base + 5 + rng.normal(0, 0.5, size=(4, 40))
    claim = Claim("A consistently beats base", "a", "above", ("base",), consistently=True)
    assert check_claim(claim, {"a": strong, "base": base}, {"a"})["verdict"] == "holds"
    weak = np.vstack([strong, base + rng.normal(0, 0.5, size=(1, 40))])  # a fifth seed no better than base
    record = check_claim(claim, {"a": weak, "base": base}, {"a"})
    assert record["comparisons"][0]["low"] > 0  # the pooled interval alone would say holds
    assert (record["verdict"], record["rule"]) == ("inconclusive", "a seed's interval contains 0")


def test_a_negative_claim_is_the_negation_of_its_positive_claim() -> None:
    """Trading's DQN on the published page: most seeds below buy-and-hold, the pooled interval wide.

    "X does not consistently outperform Y" holds because "X consistently outperforms Y" is refuted; the margin
    reading on the pooled difference (before: the only reading, inconclusive) stays as the second reading.
    """
    rng = np.random.default_rng(8)
    base = rng.normal(0, 300, size=(1, 68))
    dqn = base + np.array([[-120.0], [-150.0], [-100.0], [-130.0], [200.0], [250.0]]) + rng.normal(0, 40, (6, 68))
    negative = Claim("DQN does not consistently outperform B&H", "dqn", "not_above", ("bh",), 10.0, True)
    positive = Claim("DQN consistently outperforms B&H", "dqn", "above", ("bh",), consistently=True)
    scores = {"dqn": dqn, "bh": base}
    neg, pos = check_claim(negative, scores, {"dqn"}), check_claim(positive, scores, {"dqn"})
    assert (pos["verdict"], pos["rule"]) == ("refuted", "a seed's interval refutes")
    assert (neg["verdict"], neg["rule"], neg["positive_verdict"]) == ("holds", "negation", "refuted")
    pooled = neg["comparisons"][0]
    assert pooled["low"] < 0 < 10.0 < pooled["high"]  # the margin reading cannot tell
    assert neg["margin_reading"]["verdict"] == "inconclusive"
    assert stats.verdict("not_above", pooled["low"], pooled["high"], 10.0)[0] == "inconclusive"
    better = {"dqn": base + 500 + rng.normal(0, 5, (6, 68)), "bh": base}
    assert check_claim(negative, better, {"dqn"})["verdict"] == "refuted"  # its positive claim holds
    same = {"dqn": np.repeat(base, 6, axis=0), "bh": base}  # PPO learned buy-and-hold in every seed
    assert check_claim(negative, same, {"dqn"})["verdict"] == "holds"


def test_a_success_claim_compares_success_rates_and_shows_the_objective_beside() -> None:
    from gym4real.results.claims import quantity_scores

    rows = []
    for policy, seeds, rate in (("ppo", (0, 1), 0.75), ("fixed", (None,), 0.25)):
        for seed in seeds:
            for episode in range(8):
                won = episode < rate * 8
                rows.append(
                    {
                        "policy": policy,
                        "seed": seed,
                        "episode": episode,
                        "success": 0.5 * won,
                        "objective": 0.5 * won - 0.1,
                    }
                )
    frame = pd.DataFrame(rows)
    scores = quantity_scores(frame, "success")
    assert set(np.unique(scores["ppo"])) == {0.0, 1.0} and scores["ppo"].mean(axis=1).tolist() == [0.75, 0.75]
    objective = quantity_scores(frame, "objective")
    claim = Claim(
        "PPO succeeds more often (Sec. 2.4.1)", "ppo", "above", ("fixed",), quantity="success", section="2.4.1"
    )
    record = check_claim(claim, scores, {"ppo"}, beside=objective)
    comp = record["comparisons"][0]
    assert record["statistic"] == "mean" and comp["estimate"] == pytest.approx(0.5)
    assert comp["objective"]["estimate"] == pytest.approx(stats.iqm(objective["ppo"]) - stats.iqm(objective["fixed"]))


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
