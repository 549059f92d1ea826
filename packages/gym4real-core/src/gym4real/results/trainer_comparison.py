"""A PPO trainer other than SB3 against SB3 on one env: issue 43's *learning equal within noise*.

For an env whose page folder holds both the reference trainer's section ``<env>-<budget>`` and another
trainer's ``<env>-<budget>-<trainer>`` (the JAX trainer's: ``-jax``), the difference
``IQM(ppo-jax) - IQM(ppo)`` of the per-episode objective is computed from the two sections' ``episodes.csv``
with its 95 % two-level percentile-bootstrap interval (:func:`gym4real.bench.stats.difference_ci`): each
replicate draws the test episodes once, the same for both agents (they play the same test episodes), and each
agent's training seeds on their own (the two trainers' seeds are independent runs). :data:`RULES` decides it:
the trainer is *not detectably worse* (``holds``) unless the whole interval lies below 0 (``refuted``).

The results page computes it when it is rendered and writes it to :data:`FILE`, beside the page's ``claims.json``.
"""

from __future__ import annotations

from typing import Any

import pandas as pd

from gym4real.bench import stats
from gym4real.bench.episodes import score_matrices
from gym4real.core.errors import ConfigError
from gym4real.rl.train import label

#: The page folder's file of the trainer comparisons (a list of :func:`compare` records), beside ``claims.json``.
FILE = "trainers.json"

#: The level of the interval of a comparison.
LEVEL = 0.95

#: The claim a comparison checks (issue 43), in plain words.
CLAIM = "learning equal within noise"

#: The rules that decide a comparison, in plain words (the results page prints them).
RULES: dict[str, str] = {
    "not detectably worse": "the interval of IQM(other trainer's PPO) - IQM(SB3's PPO) contains 0 or lies above "
    "it: the other trainer does not learn detectably worse than SB3: holds",
    "detectably worse": "the whole interval lies below 0: the other trainer learns worse than SB3: refuted",
}


def verdict(low: float, high: float) -> tuple[str, str]:
    """The verdict of a trainer comparison from the interval ``[low, high]`` of the IQM difference, and its rule."""
    if high < 0:
        return "refuted", "detectably worse"
    return "holds", "not detectably worse"


def compare(
    reference: pd.DataFrame,
    other: pd.DataFrame,
    trainer: str,
    sources: tuple[str, str] = ("episodes.csv", "episodes.csv"),
    seed: int = 0,
) -> dict[str, Any]:
    """IQM(``trainer``'s PPO) - IQM(SB3's ``ppo``) of the objective, with its interval and verdict.

    Args:
        reference: ``episodes.csv`` of the SB3 section (rows of ``ppo``).
        other: ``episodes.csv`` of ``trainer``'s section (rows of its agent, ``ppo-jax`` for ``jax``).
        trainer: The other trainer (``jax``).
        sources: The two files' names, for the messages.
        seed: The seed of every bootstrap (the page's: 0).

    Returns:
        ``a`` (the other trainer's agent) and ``b`` (``ppo``), each one's seeds and IQM with its interval
        (``a_iqm``, ``a_low``, ``a_high``, the same for ``b``: the sections' ``summary.csv`` rows), the
        ``estimate``, ``low`` and ``high`` of the difference ``a - b`` at ``level``, the ``verdict`` and the
        ``rule`` (:data:`RULES`).

    Raises:
        ConfigError: A section has no rows of its agent, or the two sections' test episodes differ (named).
    """
    agent = label("ppo", trainer)
    found = []
    for frame, source, name in ((other, sources[1], agent), (reference, sources[0], "ppo")):
        scores, seeds = score_matrices(frame, source)
        if not seeds.get(name):
            raise ConfigError(f"`{source}` has no training seeds of `{name}`: the trainers cannot be compared")
        found.append((scores[name], seeds[name], sorted(set(frame["episode"].astype(int)))))
    (a, a_seeds, a_episodes), (b, b_seeds, b_episodes) = found
    if a_episodes != b_episodes:
        raise ConfigError(
            f"`{sources[1]}` and `{sources[0]}` hold different test episodes ({len(a_episodes)} and "
            f"{len(b_episodes)}): compare sections of the same test protocol"
        )
    estimate, low, high = stats.difference_ci(a, b, True, True, "iqm", seed=seed, level=LEVEL)
    record: dict[str, Any] = {"a": agent, "b": "ppo", "trainer": trainer, "a_seeds": a_seeds, "b_seeds": b_seeds}
    for key, matrix in (("a", a), ("b", b)):
        value, lo, hi = stats.iqm_ci(matrix, True, seed=seed, level=LEVEL)
        record.update({f"{key}_iqm": value, f"{key}_low": lo, f"{key}_high": hi})
    decided, rule = verdict(low, high)
    return {
        **record,
        "episodes": len(a_episodes),
        "statistic": "iqm",
        "estimate": estimate,
        "low": low,
        "high": high,
        "level": LEVEL,
        "verdict": decided,
        "rule": rule,
    }
