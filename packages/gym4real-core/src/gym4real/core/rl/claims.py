"""The rules that decide the paper's claims (:class:`~gym4real.core.specs.Claim`) from the test scores.

Every comparison of a claim is the difference ``policy - other`` of a statistic of the per-episode
objective, with its two-level (seed, episode) percentile-bootstrap interval (:mod:`gym4real.core.stats`).
:data:`RULES` says each rule in plain words; every verdict records the rule that decided it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gym4real.core import stats
from gym4real.core.specs import Claim

#: The family level of a claim: its k comparisons use Bonferroni-simultaneous intervals at 1 - 0.05 / k.
FAMILY_LEVEL = 0.95

#: Scores closer than this fraction of the largest score count as identical (see :func:`identical`).
IDENTICAL_RTOL = 1e-6

#: Every rule that can decide a comparison or a claim, in plain words (the results page prints them).
RULES: dict[str, str] = {
    "interval above 0": "the whole interval of the difference lies above 0: the policy is better (`above`), "
    "or better than the other by a detected amount (`not_above`, which then does not hold)",
    "interval below 0": "the whole interval lies below 0: the policy's IQM is lower (`below`) or its spread "
    "across test episodes is smaller (`less_variable`)",
    "interval at or below 0": "the whole interval lies at or below 0: the claimed improvement is excluded",
    "interval at or above 0": "the whole interval lies at or above 0: the claimed improvement is excluded",
    "interval contains 0": "the interval contains 0 and reaches the claimed side: the test cannot tell",
    "interval below the margin": "a negative claim (`not_above`) holds when the whole interval lies below "
    "its margin of practical equivalence: any advantage of the policy is too small to matter",
    "interval reaches the margin and 0": "a negative claim is inconclusive when the interval reaches both 0 "
    "and the margin: an advantage that matters is neither shown nor excluded",
    "identical in every episode": "the two policies score the same in every test episode and seed (to 1e-6 of "
    "the scores' magnitude): a "
    "policy cannot be better or less variable than itself, so the claim does not hold",
    "every seed": "a claim that says *consistently* also needs every training seed's IQM on the claimed side "
    "of each other policy's IQM; one seed on the other side (or equal) and the claim does not hold",
    "family": "a claim of k comparisons holds when all hold (each at level 1 - 0.05/k, Bonferroni: the k "
    "intervals cover together with probability at least 95 %), does not hold when one does not hold, and is "
    "inconclusive otherwise",
}


def statistic_of(claim: Claim) -> str:
    """The statistic a claim compares: the spread across test episodes for ``less_variable``, else the IQM."""
    return "spread" if claim.relation == "less_variable" else "iqm"


def identical(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two score matrices hold one and the same row of scores (every run, every episode).

    Scores within :data:`IDENTICAL_RTOL` of the largest score count as the same (a simulator's solver
    tolerance: wds' two single-pump policies differ by 1e-6 in a score of 100).
    """
    if a.shape[1] != b.shape[1]:
        return False
    tol = IDENTICAL_RTOL * max(float(np.abs(a).max()), float(np.abs(b).max()))
    return bool(np.all(np.abs(a - a[0]) <= tol) and np.all(np.abs(b - a[0]) <= tol))


def _seed_rule(claim: Claim, a: np.ndarray, b: np.ndarray) -> dict[str, Any]:
    """The per-seed rule of a *consistently* claim: every seed's IQM on the claimed side of ``b``'s IQM."""
    seed_iqms, _ = stats.per_seed(a)
    other = stats.iqm(b)
    side = seed_iqms > other if claim.relation == "above" else seed_iqms < other
    return {"seed_iqms": [float(v) for v in seed_iqms], "other_iqm": other, "every_seed": bool(np.all(side))}


def compare(claim: Claim, other: str, scores: dict[str, np.ndarray], trained: set[str], level: float) -> dict[str, Any]:
    """One comparison of a claim: the difference ``claim.policy - other``, its interval and verdict."""
    a, b = scores[claim.policy], scores[other]
    statistic = statistic_of(claim)
    estimate, low, high = stats.difference_ci(a, b, claim.policy in trained, other in trained, statistic, level=level)
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
    if claim.relation != "not_above" and identical(a, b):
        record.update(verdict="does not hold", rule="identical in every episode")
        return record
    record["verdict"], record["rule"] = stats.verdict(claim.relation, low, high, claim.margin)
    if claim.consistently:
        record["seeds"] = _seed_rule(claim, a, b)
        if not record["seeds"]["every_seed"]:
            record.update(verdict="does not hold", rule="every seed")
    return record


def check_claim(claim: Claim, scores: dict[str, np.ndarray], trained: set[str]) -> dict[str, Any]:
    """The verdict of one claim, with every comparison and the rule that decided it.

    Args:
        claim: The claim.
        scores: Policy -> score matrix ``(runs, episodes)`` of the per-episode objective.
        trained: The policies whose rows are training seeds.
    """
    level = 1 - (1 - FAMILY_LEVEL) / len(claim.others)
    record: dict[str, Any] = {
        "text": claim.text,
        "policy": claim.policy,
        "relation": claim.relation,
        "statistic": statistic_of(claim),
        "margin": claim.margin,
        "consistently": claim.consistently,
        "family_level": FAMILY_LEVEL,
        "level": level,
        "comparisons": [],
    }
    missing = [p for p in (claim.policy, *claim.others) if p not in scores]
    if missing:
        record.update(verdict="not checked", rule=f"no test scores of {missing}", deciding=None)
        return record
    comps = [compare(claim, other, scores, trained, level) for other in claim.others]
    record["comparisons"] = comps
    for verdict in ("does not hold", "inconclusive"):
        found = [c for c in comps if c["verdict"] == verdict]
        if found:
            record.update(verdict=verdict, rule=found[0]["rule"], deciding=found[0]["b"])
            return record
    # every comparison holds: the deciding one is the closest to failing (the interval nearest 0 or the margin)
    if claim.relation == "above":
        closest = min(comps, key=lambda c: c["low"])
    elif claim.relation == "not_above":
        closest = max(comps, key=lambda c: c["high"])
    else:
        closest = max(comps, key=lambda c: c["high"])
    record.update(verdict="holds", rule="family", deciding=closest["b"])
    return record
