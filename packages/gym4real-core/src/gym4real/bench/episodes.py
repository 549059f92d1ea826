"""The table of test episodes: one row per policy, training seed and test episode, read into score matrices.

``gym4real reproduce`` writes it (``<env>-<budget>/episodes.csv``), the domains ship it as reference runs,
and the results page, the claims and ``gym4real evaluate`` read it with :func:`score_matrices`, the one reader.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from gym4real.core.errors import ConfigError


def score_matrices(
    frame: pd.DataFrame, source: str, column: str = "objective"
) -> tuple[dict[str, np.ndarray], dict[str, list[int]]]:
    """Policy -> its ``(seeds, episodes)`` matrix of ``column``, and policy -> its training seeds.

    A policy with seeds (an RL algorithm) has one row per seed, in increasing seed order, and its seeds
    listed; a baseline (empty ``seed``) has one row and no seeds. Policies keep the order of the table,
    episodes are in increasing order.

    Args:
        frame: The table (columns ``policy``, ``seed``, ``episode`` and ``column`` at least).
        source: The file it was read from, for the messages.
        column: The score to read (``objective``, ``return`` or a reward component).

    Raises:
        ConfigError: A missing column, a missing or non-finite score, a policy with rows both with and
            without a seed, or a policy without every seed's every test episode ``0..E-1`` once (named).
    """
    missing = [c for c in ("policy", "seed", "episode", column) if c not in frame.columns]
    if missing:
        raise ConfigError(f"`{source}` has no column {missing}; write the table with `policy, seed, episode, {column}`")
    values = pd.to_numeric(frame[column], errors="coerce")
    if not np.all(np.isfinite(values)):
        raise ConfigError(f"`{source}`: the column `{column}` holds a missing or non-finite value")
    frame = frame.assign(**{column: values.astype(float)})
    episodes = sorted(set(frame["episode"].astype(int)))
    scores: dict[str, np.ndarray] = {}
    seeds: dict[str, list[int]] = {}
    for policy, rows in frame.groupby("policy", sort=False):
        trained = bool(rows["seed"].notna().all())
        if rows["seed"].notna().any() and not trained:
            raise ConfigError(f"`{source}`: policy `{policy}` has rows with and without a seed; give every row one")
        keyed = rows.assign(seed=rows["seed"].astype(int) if trained else 0, episode=rows["episode"].astype(int))
        complete = keyed.groupby("seed")["episode"].agg(lambda e: sorted(e) == episodes).all()
        if keyed.duplicated(["seed", "episode"]).any() or not complete:
            raise ConfigError(
                f"`{source}`: policy `{policy}` does not have one row per seed and test episode {episodes[0]}.."
                f"{episodes[-1]}; write the table with every seed's every episode"
            )
        matrix = keyed.pivot(index="seed", columns="episode", values=column)
        scores[str(policy)] = matrix.to_numpy(dtype=float)
        seeds[str(policy)] = [int(s) for s in matrix.index] if trained else []
    return scores, seeds
