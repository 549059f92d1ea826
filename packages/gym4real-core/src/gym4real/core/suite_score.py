"""The suite score: one scale across the suite's environments, aggregated over environments and seeds.

**Scale.** On each environment a score is normalised so that 0 is the ``random`` baseline and 1 is the
best rule-based baseline the paper compares with (the domain declares which of its baselines are
rule-based: ``BenchmarkSpec.rule_based``); both anchors are interquartile means (IQM) of the
per-episode objective over the test protocol, so that the normalised IQM of the best rule-based baseline
is exactly 1 and that of ``random`` exactly 0. As Atari's human-normalised score measures an agent
against a competent player who does not learn, this scale measures an RL agent against what a
practitioner would deploy without learning: the rule an operator writes by hand. Above 1, the agent
beats every rule of the paper; between 0 and 1, it learnt something but not yet a rule's worth; below 0,
it is worse than acting at random. Unlike a "best known
score" the anchors never move as agents improve, and unlike an oracle they exist on every environment
without privileged information.

**Special cases.** The scale is affine, so the sign and range of an objective do not matter: a cost
objective (dam: never above 0) and a success rate (robofeeder: in [0, 1]) normalise alike, and a
perfect agent on a one-sided objective gets a finite score (a cost of 0 gives ``-random / (best -
random)``). A rule-based baseline worse than ``random`` (trading: a passive position in a falling
market) gets a negative score; it is still a baseline, and only the best one is the anchor. An
environment where no rule-based baseline is better than ``random`` (the two anchors equal, or random
ahead), or that has no rule-based baseline (robofeeder planning: its baselines are a simulator-reading
oracle and a pretrained agent), has no scale: its scores are reported in its own objective and it is left
out of the aggregate, with the reason.

**Aggregate.** A run (one training seed on one environment) scores the IQM of its normalised test
episodes. The aggregate over environments and seeds is the interquartile mean (IQM) of the runs, with a
stratified percentile bootstrap (each replicate resamples the seeds within each environment, as
rliable's ``StratifiedBootstrap``); the optimality gap is the mean shortfall of the runs below 1 (how far
the agent is from the best rule, runs above 1 counting 0); the performance profile is the fraction of
runs above each score.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats as sps

#: Bootstrap replicates of the aggregate intervals.
REPS = 5000
#: Thresholds of the suite's performance profile (normalised score).
THRESHOLDS = np.linspace(-0.5, 2.0, 101)
#: Anchors closer than this (relative to their size) are equal: the environment has no scale.
TOLERANCE = 1e-9


@dataclass(frozen=True)
class Scale:
    """The normalisation of one environment's objective: ``random`` -> 0, ``best`` -> 1.

    Attributes:
        env_id: The environment.
        random: IQM of the ``random`` baseline's objective over the test episodes (NaN if it has none).
        best: The best rule-based baseline (None if the environment has none).
        top: Its IQM (NaN if none).
        note: Why the environment has no scale; empty when it has one.
    """

    env_id: str
    random: float
    best: str | None
    top: float
    note: str = ""

    @property
    def usable(self) -> bool:
        """Whether scores of this environment can be normalised."""
        return not self.note

    def normalise(self, scores: Any) -> Any:
        """``(scores - random) / (top - random)``: increasing, so it maps an IQM and its interval to theirs."""
        return (np.asarray(scores, dtype=float) - self.random) / (self.top - self.random)


def scale(env_id: str, anchors: Mapping[str, float], rule_based: Sequence[str]) -> Scale:
    """The scale of an environment from its baselines' IQMs.

    Args:
        env_id: The environment.
        anchors: Baseline -> IQM of its objective over the test episodes (``random`` among them).
        rule_based: The environment's rule-based baselines (``BenchmarkSpec.rule_based``).
    """
    from gym4real.core.upper_reference import non_causal

    random = float(anchors.get("random", np.nan))
    upper = set(non_causal(env_id))  # an upper reference knows the future: never the 1 of the scale
    candidates = [b for b in rule_based if b in anchors and b not in upper]
    if "random" not in anchors:
        return Scale(env_id, random, None, np.nan, "no `random` baseline was run")
    if not candidates:
        return Scale(env_id, random, None, np.nan, "no rule-based baseline (the 1 of the scale)")
    best = max(candidates, key=lambda b: anchors[b])
    top = float(anchors[best])
    if top - random <= TOLERANCE * max(1.0, abs(top), abs(random)):
        return Scale(
            env_id,
            random,
            best,
            top,
            f"no rule-based baseline beats `random` (best `{best}`: {top:.6g}, random {random:.6g})",
        )
    return Scale(env_id, random, best, top)


def run_scores(scores: np.ndarray, env_scale: Scale) -> np.ndarray:
    """Normalised score of each run (row) of a ``(seeds, episodes)`` matrix: the IQM of its normalised episodes.

    The IQM is taken first and then normalised (the same number, as the scale is affine), so that a run
    identical to an anchor scores exactly 0 or 1.
    """
    runs: np.ndarray = env_scale.normalise(iqm_of_rows(np.asarray(scores, dtype=float)))
    return runs


def iqm_of_rows(x: np.ndarray) -> np.ndarray:
    """IQM of each row of ``(batch, runs)``."""
    result: np.ndarray = sps.trim_mean(x, 0.25, axis=1)
    return result


def optimality_gap_of_rows(x: np.ndarray, target: float = 1.0) -> np.ndarray:
    """Mean shortfall below ``target`` of each row of ``(batch, runs)`` (rliable's optimality gap)."""
    result: np.ndarray = np.mean(np.maximum(target - x, 0.0), axis=1)
    return result


def stratified_replicates(runs: Sequence[np.ndarray], reps: int = REPS, seed: int = 0) -> np.ndarray:
    """Bootstrap replicates ``(reps, total runs)``: in each, every environment's runs resampled among its own.

    Args:
        runs: Per environment, the normalised scores of its runs (seeds).
        reps: Number of replicates.
        seed: Seed of the resampling.
    """
    rng = np.random.default_rng(seed)
    parts = [np.asarray(r, dtype=float)[rng.integers(0, len(r), size=(reps, len(r)))] for r in runs]
    return np.concatenate(parts, axis=1)


def aggregate(
    runs: Sequence[np.ndarray], statistic: Callable[[np.ndarray], np.ndarray], seed: int = 0
) -> tuple[float, float, float]:
    """``statistic`` over all runs of all environments, and its stratified-bootstrap 95 % interval."""
    point = float(statistic(np.concatenate([np.asarray(r, dtype=float) for r in runs])[None, :])[0])
    low, high = np.percentile(statistic(stratified_replicates(runs, seed=seed)), [2.5, 97.5])
    return point, float(low), float(high)


def summary(runs: Mapping[str, np.ndarray]) -> dict[str, Any]:
    """An agent's suite score from its runs per environment (env id -> normalised run scores).

    Returns the IQM and the optimality gap over every run, each with its stratified-bootstrap 95 % interval
    (``iqm, low, high, optimality_gap, optimality_gap_low, optimality_gap_high``), the environments and
    the number of runs; the numbers are None without any run.
    """
    if not runs:
        return {"iqm": None, "low": None, "high": None, "optimality_gap": None, "envs": [], "runs": 0}
    parts = list(runs.values())
    iqm, low, high = aggregate(parts, iqm_of_rows)
    gap, gap_low, gap_high = aggregate(parts, optimality_gap_of_rows)
    return {
        "iqm": iqm,
        "low": low,
        "high": high,
        "optimality_gap": gap,
        "optimality_gap_low": gap_low,
        "optimality_gap_high": gap_high,
        "envs": list(runs),
        "runs": int(sum(len(r) for r in parts)),
    }


def suite_profile(
    runs: Sequence[np.ndarray], thresholds: np.ndarray, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fraction of runs above each threshold, with its stratified-bootstrap 95 % band: ``(profile, low, high)``."""
    taus = np.asarray(thresholds, dtype=float)
    pooled = np.concatenate([np.asarray(r, dtype=float) for r in runs])
    profile = np.mean(pooled[None, :] > taus[:, None], axis=1)
    replicates = stratified_replicates(runs, seed=seed)
    fractions = np.mean(replicates[:, None, :] > taus[None, :, None], axis=2)
    low, high = np.percentile(fractions, [2.5, 97.5], axis=0)
    return profile, low, high
