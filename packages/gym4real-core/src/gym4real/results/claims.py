"""The rules that decide the paper's claims (:class:`~gym4real.core.specs.Claim`) from the test scores.

Every comparison of a claim is the difference ``policy - other`` of a statistic of the per-episode quantity
(the objective, or an episode's success), with its two-level (seed, episode) percentile-bootstrap interval
(:mod:`gym4real.bench.stats`); a *consistently* claim also takes each training seed's own interval (its test
episodes resampled, paired with the other policy). No verdict rests on a point estimate. :data:`VERDICTS`
defines the three verdict words and :data:`RULES` each rule in plain words; every verdict records the rule
that decided it.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pandas as pd

from gym4real.bench import stats
from gym4real.bench.episodes import score_matrices
from gym4real.core.specs import Claim
from gym4real.rl.train import label

#: The family level of a claim: its m intervals are Bonferroni-simultaneous, each at 1 - 0.05 / m.
FAMILY_LEVEL = 0.95

#: Scores closer than this fraction of the largest score count as identical (see :func:`identical`).
IDENTICAL_RTOL = 1e-6

#: The three verdicts, each in plain words (the results page defines them once).
VERDICTS: dict[str, str] = {
    "holds": "the intervals show what the claim says, at the claim's 95 % family level",
    "refuted": "the intervals show the opposite of what the claim says (for *X is better than Y*: X is not "
    "better; for a negative claim: the positive claim it negates holds)",
    "inconclusive": "the intervals show neither: the data cannot tell",
}

#: What each quantity of a claim is per episode, and the statistic that compares it.
QUANTITIES: dict[str, str] = {
    "objective": "the per-episode objective, compared by its IQM (the spread across test episodes for a claim "
    "of lower variability)",
    "success": "1 for an episode whose object was picked (its `success` reward component is positive), else 0, "
    "compared by its mean: the success rate (per seed: the fraction of its test episodes that succeed)",
}

#: Every rule that can decide a comparison or a claim, in plain words (the results page prints them).
RULES: dict[str, str] = {
    "interval above 0": "the whole interval of the difference lies above 0: the policy is better (`above`: "
    "holds), or better by a detected amount (margin reading of a negative claim: refuted)",
    "interval below 0": "the whole interval lies below 0: the policy's statistic is lower (`below`) or its spread "
    "across test episodes is smaller (`less_variable`): holds",
    "interval at or below 0": "the whole interval lies at or below 0: the claimed improvement is excluded: refuted",
    "interval at or above 0": "the whole interval lies at or above 0: the claimed reduction is excluded: refuted",
    "interval contains 0": "the interval contains 0 and reaches the claimed side: inconclusive",
    "identical in every episode": "the two policies score the same in every test episode and seed (to 1e-6 of "
    "the scores' magnitude): a policy cannot be better or less variable than itself: refuted",
    "a seed's interval refutes": "a *consistently* claim is refuted by one training seed whose own interval "
    "(its test episodes resampled, paired with the other policy) lies on the other side (at or below 0 for "
    "*better*)",
    "a seed's interval contains 0": "a *consistently* claim whose pooled interval holds is inconclusive while "
    "a seed's own interval contains 0: that seed is neither shown better nor shown not better",
    "negation": 'a negative claim ("X does not consistently outperform Y") is the negation of its positive claim '
    '("X consistently outperforms Y"): it holds when the positive claim is refuted, is refuted when it holds, '
    "and is inconclusive otherwise",
    "interval below the margin": "margin reading of a negative claim (second, stricter reading, on the pooled "
    "difference): holds when the whole interval lies below the margin of practical equivalence: any advantage "
    "of the policy is too small to matter",
    "interval reaches the margin and 0": "margin reading: inconclusive when the interval reaches both 0 and the "
    "margin: an advantage that matters is neither shown nor excluded",
    "family": "a claim of m intervals (k comparisons; for *consistently*, k x (1 + seeds): the pooled and each "
    "seed's) takes each at level 1 - 0.05/m (Bonferroni: the m intervals cover together with probability at "
    "least 95 %); it holds when every one holds, is refuted when one is refuted, and is inconclusive otherwise",
}


def trained_by(trainer: str) -> str:
    """How a section of a trainer other than SB3 names its agent: ``PPO trained by the JAX trainer, `ppo-jax```."""
    return f"PPO trained by the {trainer.upper()} trainer, `{label('ppo', trainer)}`"


def on_trainer(claim: Claim, trainer: str) -> Claim:
    """The claim as a section of ``trainer``'s runs checks it: its PPO agent is the one that trainer trained.

    The protocol's claims name ``ppo``, the agent of the reference trainer (SB3); a section of the JAX
    trainer's runs holds ``ppo-jax`` in its place (:func:`gym4real.rl.train.label`). Every ``ppo`` of the
    claim (its policy and the others) becomes that agent, and its text says so (:func:`trained_by`). An SB3
    section's claims are returned as they are.
    """
    if trainer == "sb3":
        return claim
    agent = label("ppo", trainer)

    def swap(policy: str) -> str:
        return agent if policy == "ppo" else policy

    return replace(
        claim,
        text=f"{claim.text} ({trained_by(trainer)})",
        policy=swap(claim.policy),
        others=tuple(swap(p) for p in claim.others),
    )


def statistic_of(claim: Claim) -> str:
    """The statistic a claim compares: the spread for ``less_variable``, the mean (rate) of a success, else IQM."""
    if claim.relation == "less_variable":
        return "spread"
    return "mean" if claim.quantity == "success" else "iqm"


def quantity_scores(episodes: pd.DataFrame, quantity: str, source: str = "episodes.csv") -> dict[str, np.ndarray]:
    """Policy -> its ``(seeds, episodes)`` matrix of a claim's per-episode quantity (see :data:`QUANTITIES`).

    Raises:
        ConfigError: ``episodes`` lacks the quantity's column (named) or holds a non-finite value in it.
        ValueError: An unknown quantity.
    """
    if quantity == "objective":
        return score_matrices(episodes, source, "objective")[0]
    if quantity == "success":
        return {p: (m > 0).astype(float) for p, m in score_matrices(episodes, source, "success")[0].items()}
    raise ValueError(f"quantity `{quantity}` is not one of {list(QUANTITIES)}")


def identical(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two score matrices hold one and the same row of scores (every run, every episode).

    Scores within :data:`IDENTICAL_RTOL` of the largest score count as the same (a simulator's solver
    tolerance: wds' two single-pump policies differ by 1e-6 in a score of 100).
    """
    if a.shape[1] != b.shape[1]:
        return False
    tol = IDENTICAL_RTOL * max(float(np.abs(a).max()), float(np.abs(b).max()))
    return bool(np.all(np.abs(a - a[0]) <= tol) and np.all(np.abs(b - a[0]) <= tol))


def _positive(claim: Claim) -> str:
    """The relation of the comparisons: a negative claim (``not_above``) compares as its positive, ``above``."""
    return "above" if claim.relation == "not_above" else claim.relation


def _seed_rule(
    claim: Claim,
    a: np.ndarray,
    b: np.ndarray,
    b_trained: bool,
    level: float,
    seed_ids: list[int] | None,
    bootstrap_seed: int = 0,
) -> list[dict[str, Any]]:
    """Each training seed of ``a`` against ``b``: its own interval of the difference and that interval's verdict."""
    estimates, lows, highs = stats.per_seed_difference_ci(
        a, b, b_trained, statistic_of(claim), seed=bootstrap_seed, level=level
    )
    ids = seed_ids if seed_ids is not None and len(seed_ids) == len(a) else list(range(len(a)))
    rows = []
    for seed, estimate, low, high in zip(ids, estimates, lows, highs, strict=True):
        verdict, _ = stats.verdict(_positive(claim), float(low), float(high))
        rows.append(
            {"seed": int(seed), "estimate": float(estimate), "low": float(low), "high": float(high), "verdict": verdict}
        )
    return rows


def compare(
    claim: Claim,
    other: str,
    scores: dict[str, np.ndarray],
    trained: set[str],
    level: float,
    seed_ids: list[int] | None = None,
    beside: dict[str, np.ndarray] | None = None,
    bootstrap_seed: int = 0,
) -> dict[str, Any]:
    """One comparison of a claim: the difference ``claim.policy - other``, its interval and verdict.

    The verdict is that of the positive comparison (``policy`` above ``other`` for a negative claim).

    Args:
        claim: The claim.
        other: The policy compared with.
        scores: Policy -> score matrix ``(runs, episodes)`` of the claim's quantity.
        trained: The policies whose rows are training seeds.
        level: The level of every interval of the comparison.
        seed_ids: The training seeds of ``claim.policy``'s rows (for the record).
        beside: Policy -> objective matrix, when the claim's quantity is not the objective: the IQM difference
            of the objective is recorded beside (``objective``), not deciding anything.
        bootstrap_seed: The seed of every bootstrap of the comparison.
    """
    a, b = scores[claim.policy], scores[other]
    statistic = statistic_of(claim)
    a_trained, b_trained = claim.policy in trained, other in trained
    estimate, low, high = stats.difference_ci(a, b, a_trained, b_trained, statistic, bootstrap_seed, level)
    record: dict[str, Any] = {
        "a": claim.policy,
        "b": other,
        "statistic": statistic,
        "estimate": estimate,
        "low": low,
        "high": high,
        "level": level,
        "detectable": (high - low) / 2,
    }
    if beside is not None:
        e, lo, hi = stats.difference_ci(
            beside[claim.policy], beside[other], a_trained, b_trained, seed=bootstrap_seed, level=level
        )
        record["objective"] = {"statistic": "iqm", "estimate": e, "low": lo, "high": hi}
    if claim.relation == "not_above":
        record["margin_verdict"], record["margin_rule"] = stats.verdict("not_above", low, high, claim.margin)
    if identical(a, b):
        record.update(verdict="refuted", rule="identical in every episode")
        return record
    record["verdict"], record["rule"] = stats.verdict(_positive(claim), low, high)
    if claim.consistently:
        seeds = _seed_rule(claim, a, b, b_trained, level, seed_ids, bootstrap_seed)
        record["seeds"] = seeds
        verdicts = {s["verdict"] for s in seeds}
        if record["verdict"] != "refuted" and "refuted" in verdicts:
            record.update(verdict="refuted", rule="a seed's interval refutes")
        elif record["verdict"] == "holds" and verdicts != {"holds"}:
            record.update(verdict="inconclusive", rule="a seed's interval contains 0")
    return record


def _family(comps: list[dict[str, Any]], relation: str, key: str = "verdict") -> tuple[str, str, str]:
    """The family verdict of comparisons: ``(verdict, rule, deciding policy)`` (see ``RULES["family"]``)."""
    rule_key = "rule" if key == "verdict" else "margin_rule"
    for verdict in ("refuted", "inconclusive"):
        found = [c for c in comps if c[key] == verdict]
        if found:
            return verdict, found[0][rule_key], found[0]["b"]
    # every comparison holds: the deciding one is the closest to failing (the interval nearest 0 or the margin)
    closest = min(comps, key=lambda c: c["low"]) if relation == "above" else max(comps, key=lambda c: c["high"])
    return "holds", "family", closest["b"]


def negation(verdict: str) -> str:
    """The verdict of a claim's negation: ``holds`` <-> ``refuted``; ``inconclusive`` stays."""
    return {"holds": "refuted", "refuted": "holds"}.get(verdict, verdict)


def intervals_of(claim: Claim, runs: int) -> int:
    """The number m of intervals a claim's verdict rests on: k comparisons, times (1 + seeds) for *consistently*."""
    return len(claim.others) * (1 + runs if claim.consistently else 1)


def check_claim(
    claim: Claim,
    scores: dict[str, np.ndarray],
    trained: set[str],
    seed_ids: list[int] | None = None,
    beside: dict[str, np.ndarray] | None = None,
    bootstrap_seed: int = 0,
) -> dict[str, Any]:
    """The verdict of one claim, with every comparison and the rule that decided it.

    Args:
        claim: The claim.
        scores: Policy -> score matrix ``(runs, episodes)`` of the claim's quantity (:func:`quantity_scores`).
        trained: The policies whose rows are training seeds.
        seed_ids: The training seeds of ``claim.policy``'s rows (for the record).
        beside: Policy -> objective matrix, shown beside a claim on another quantity (see :func:`compare`).
        bootstrap_seed: The seed of every bootstrap (the published verdicts: 0).
    """
    record: dict[str, Any] = {
        "text": claim.text,
        "paper": claim.paper,
        "section": claim.section,
        "policy": claim.policy,
        "relation": claim.relation,
        "quantity": claim.quantity,
        "statistic": statistic_of(claim),
        "margin": claim.margin,
        "consistently": claim.consistently,
        "family_level": FAMILY_LEVEL,
        "level": 1 - (1 - FAMILY_LEVEL) / len(claim.others),
        "comparisons": [],
    }
    missing = [p for p in (claim.policy, *claim.others) if p not in scores]
    if missing:
        record.update(verdict="not checked", rule=f"no test scores of {missing}", deciding=None)
        return record
    level = 1 - (1 - FAMILY_LEVEL) / intervals_of(claim, len(scores[claim.policy]))
    record["level"] = level
    comps = [compare(claim, other, scores, trained, level, seed_ids, beside, bootstrap_seed) for other in claim.others]
    record["comparisons"] = comps
    verdict, rule, deciding = _family(comps, _positive(claim))
    if claim.relation == "not_above":
        record["positive_verdict"] = verdict
        margin_verdict, margin_rule, margin_deciding = _family(comps, "not_above", "margin_verdict")
        record["margin_reading"] = {"verdict": margin_verdict, "rule": margin_rule, "deciding": margin_deciding}
        verdict, rule = negation(verdict), "negation"
    record.update(verdict=verdict, rule=rule, deciding=deciding)
    return record
