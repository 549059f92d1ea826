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
market) gets a negative score; it is still a baseline, and only the best one is the anchor.

**A scale must separate its anchors.** The 1-anchor must beat the 0-anchor on the protocol, not by
chance: the IQM difference ``best - random`` over the test episodes, with its 95 % percentile-bootstrap
interval (the episodes resampled, both anchors on the same ones: :func:`gym4real.bench.stats.difference_ci`),
must lie above 0. An environment whose anchors are not separated (trading: ``buy_and_hold - random`` is
within the noise of its 68 test days), or that has no rule-based baseline (robofeeder planning: its
baselines are a simulator-reading oracle and a pretrained agent), has no scale: its scores are reported
in its own objective and it is left out of the aggregate, with the reason (the measured difference).

**Aggregate.** A run (one training seed on one environment) scores the IQM of its normalised test
episodes. The aggregate over environments and seeds is the interquartile mean (IQM) of the runs, with a
stratified two-level percentile bootstrap: each replicate, within each environment, draws the agent's
seeds with replacement and the test episodes with replacement (one draw of episodes shared by all its
seeds, as :mod:`gym4real.bench.stats` does for one environment), and recomputes every run's score on them;
environments are strata, each keeping its number of runs (rliable's ``StratifiedBootstrap``, with the
episodes as a second level). A deterministic agent, whose seeds are one policy, thus gets the width its
test episodes give. The scale itself is fixed: its anchors are the IQMs measured on the test protocol.
The **shortfall below the best rule** is the mean shortfall of the runs below 1 (rliable's "optimality gap"
with the best rule as its target: how far the agent is from the best rule, runs above 1 counting 0; it is not a
distance to an optimum, which the scale does not reach: :mod:`gym4real.bench.upper_reference` measures that);
the performance profile is the fraction of runs above each score. Agents trained on different environments
have suite scores over different strata: compare them per environment, not by the aggregate.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gym4real.bench import stats

#: Bootstrap replicates of the aggregate 95 % intervals (:func:`gym4real.bench.stats.replicates_at`).
REPS = stats.replicates_at(0.95)
#: Thresholds of the suite's performance profile (normalised score).
THRESHOLDS = np.linspace(-0.5, 2.0, 101)
#: The 0-anchor of every scale.
ZERO = "random"


@dataclass(frozen=True)
class Scale:
    """The normalisation of one environment's objective: ``random`` -> 0, ``best`` -> 1.

    Attributes:
        env_id: The environment.
        random: IQM of the ``random`` baseline's objective over the test episodes (NaN if it has none).
        best: The best rule-based baseline (None if the environment has none).
        top: Its IQM (NaN if none).
        note: Why the environment has no scale; empty when it has one.
        difference: ``(estimate, low, high)``: IQM ``best - random`` and its 95 % interval, episodes
            resampled in pairs; None without both anchors.
    """

    env_id: str
    random: float
    best: str | None
    top: float
    note: str = ""
    difference: tuple[float, float, float] | None = None

    @property
    def usable(self) -> bool:
        """Whether scores of this environment can be normalised (its anchors are separated)."""
        return not self.note

    @property
    def separated(self) -> bool:
        """Whether the 1-anchor beats the 0-anchor with a 95 % interval of their difference above 0."""
        return self.difference is not None and self.difference[1] > 0

    def words(self, quote: str = "") -> str:
        """The scale in words: its anchors and their separated difference, or why the env has none.

        Args:
            quote: Put around policy names (a backtick in Markdown).
        """
        if not self.usable or self.difference is None:
            return f"no normalised scale: {self.note}"
        estimate, low, high = self.difference
        zero, one = f"{quote}{ZERO}{quote}", f"{quote}{self.best}{quote}"
        return (
            f"scale: 0 = {zero} ({self.random:.6g}), 1 = {one} ({self.top:.6g}); separated: "
            f"IQM {one} - {zero} = {estimate:.5g} [{low:.5g}, {high:.5g}]"
        )

    def record(self) -> dict[str, Any]:
        """The scale as ``score.json`` gives it: ``{"zero", "one", "separated", "difference": [low, high]}``."""
        interval = None if self.difference is None else [self.difference[1], self.difference[2]]
        return {"zero": ZERO, "one": self.best, "separated": self.separated, "difference": interval}

    def normalise(self, scores: Any) -> Any:
        """``(scores - random) / (top - random)``: increasing, so it maps an IQM and its interval to theirs."""
        return (np.asarray(scores, dtype=float) - self.random) / (self.top - self.random)


def scale(env_id: str, baselines: Mapping[str, np.ndarray], rule_based: Sequence[str]) -> Scale:
    """The scale of an environment from its baselines' scores on the test protocol.

    Args:
        env_id: The environment.
        baselines: Baseline -> its per-episode objective, ``(1, episodes)`` (``random`` among them), every
            baseline on the same test episodes.
        rule_based: The environment's rule-based baselines (``BenchmarkSpec.rule_based``).
    """
    from gym4real.core.registry import non_causal

    scores = {name: np.atleast_2d(np.asarray(m, dtype=float)) for name, m in baselines.items()}
    iqms = {name: stats.iqm(m) for name, m in scores.items()}
    random = iqms.get(ZERO, np.nan)
    upper = set(non_causal(env_id))  # an upper reference knows the future: never the 1 of the scale
    candidates = [b for b in rule_based if b in scores and b not in upper]
    if ZERO not in scores:
        return Scale(env_id, random, None, np.nan, f"no `{ZERO}` baseline was run")
    if not candidates:
        return Scale(env_id, random, None, np.nan, "no rule-based baseline (the 1 of the scale)")
    best = max(candidates, key=lambda b: iqms[b])
    difference = stats.difference_ci(scores[best], scores[ZERO], False, False, "iqm")
    found = Scale(env_id, random, best, iqms[best], difference=difference)
    if found.separated:
        return found
    estimate, low, high = difference
    return Scale(
        env_id,
        random,
        best,
        iqms[best],
        f"no rule-based baseline beats `{ZERO}` with a 95 % interval above 0 (IQM `{best}` - `{ZERO}`: "
        f"{estimate:,.4g} [{low:,.4g}, {high:,.4g}])",
        difference,
    )


#: What the aggregate takes: env id -> (a policy's per-episode objective ``(seeds, episodes)``, the env's scale).
Runs = Mapping[str, tuple[np.ndarray, Scale]]


def run_scores(scores: np.ndarray, env_scale: Scale) -> np.ndarray:
    """Normalised score of each run (row) of a ``(seeds, episodes)`` matrix: the IQM of its normalised episodes.

    The IQM is taken first and then normalised (the same number, as the scale is affine), so that a run
    identical to an anchor scores exactly 0 or 1.
    """
    runs: np.ndarray = env_scale.normalise(iqm_of_rows(np.asarray(scores, dtype=float)))
    return runs


def iqm_of_rows(x: np.ndarray) -> np.ndarray:
    """IQM of each row of ``(batch, runs)`` (of the last axis of any array)."""
    return stats.iqm_last(x)


def shortfall_of_rows(x: np.ndarray, target: float = 1.0) -> np.ndarray:
    """Mean shortfall below ``target`` (the best rule) of each row of ``(batch, runs)`` (rliable's optimality gap)."""
    result: np.ndarray = np.mean(np.maximum(target - x, 0.0), axis=1)
    return result


def pooled(runs: Runs) -> np.ndarray:
    """The normalised score of every run of every environment, one array."""
    return np.concatenate([run_scores(matrix, env_scale) for matrix, env_scale in runs.values()])


def stratified_replicates(runs: Runs, reps: int = REPS, seed: int = 0) -> np.ndarray:
    """Bootstrap replicates of the run scores, ``(reps, total runs)``, stratified by environment.

    In each replicate and environment, the seeds (rows) are drawn with replacement and the test episodes
    (columns) with replacement, one draw of episodes for all the rows (:func:`gym4real.bench.stats.resample`);
    each drawn run scores the normalised IQM of its drawn episodes.

    Args:
        runs: Env id -> a policy's scores there and the env's scale (see :data:`Runs`).
        reps: Number of replicates.
        seed: Seed of the resampling.
    """
    rng = np.random.default_rng(seed)
    parts = []
    for matrix, env_scale in runs.values():
        (drawn,) = stats.resample([np.asarray(matrix, dtype=float)], [True], rng, reps)
        parts.append(env_scale.normalise(iqm_of_rows(drawn)))
    return np.concatenate(parts, axis=1)


def aggregate(
    runs: Runs, statistic: Callable[[np.ndarray], np.ndarray], seed: int = 0, reps: int = REPS
) -> tuple[float, float, float]:
    """``statistic`` over all runs of all environments, and its stratified two-level bootstrap 95 % interval."""
    point = float(statistic(pooled(runs)[None, :])[0])
    low, high = np.percentile(statistic(stratified_replicates(runs, reps, seed)), [2.5, 97.5])
    return point, float(low), float(high)


def summary(runs: Runs) -> dict[str, Any]:
    """An agent's suite score from its scores per environment (env id -> its matrix and the env's scale).

    Returns the IQM and the shortfall below the best rule over every run, each with its stratified two-level
    bootstrap 95 % interval (``iqm, low, high, shortfall, shortfall_low, shortfall_high``), the environments,
    the number of runs and each environment's normalised score (``per_env``: env id -> the IQM of the agent's
    episodes there, all seeds pooled, on the env's scale); the numbers are None without any run.
    """
    if not runs:
        return {"iqm": None, "low": None, "high": None, "shortfall": None, "envs": [], "runs": 0, "per_env": {}}
    iqm, low, high = aggregate(runs, iqm_of_rows)
    gap, gap_low, gap_high = aggregate(runs, shortfall_of_rows)
    return {
        "iqm": iqm,
        "low": low,
        "high": high,
        "shortfall": gap,
        "shortfall_low": gap_low,
        "shortfall_high": gap_high,
        "envs": list(runs),
        "runs": int(sum(np.asarray(m).shape[0] for m, _ in runs.values())),
        "per_env": {env: float(env_scale.normalise(stats.iqm(m))) for env, (m, env_scale) in runs.items()},
    }


def suite_profile(
    runs: Runs, thresholds: np.ndarray, seed: int = 0, reps: int = REPS
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fraction of runs above each threshold, with its stratified-bootstrap 95 % band: ``(profile, low, high)``."""
    taus = np.asarray(thresholds, dtype=float)
    profile = np.mean(pooled(runs)[None, :] > taus[:, None], axis=1)
    replicates = stratified_replicates(runs, reps, seed)
    fractions = np.mean(replicates[:, None, :] > taus[None, :, None], axis=2)
    low, high = np.percentile(fractions, [2.5, 97.5], axis=0)
    return profile, low, high
