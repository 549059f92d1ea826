"""The statistics of an environment's reproduced results, computed from its ``episodes.csv`` alone.

``episodes.csv`` holds one row per policy, training seed (empty for a baseline) and test episode, with the
per-episode ``objective`` (the score), the ``return`` and one column per reward component. Every number
of the results page about test scores is computed here from that file, with the seeded two-level
bootstrap of :mod:`gym4real.bench.stats`, so that anyone can recompute it:

- ``summary.csv``: per policy, the IQM of the objective with its 95 % interval, mean, spread, mean return;
- ``improvement.csv``: per RL algorithm and baseline, rliable's probability of improvement with its interval;
- ``claims.json`` (per env): every claim of the paper checked (:mod:`gym4real.results.claims`);
- ``performance_profile.png``: the fraction of (run, episode) scores above each threshold, per policy.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from gym4real.bench import stats
from gym4real.bench.episodes import score_matrices
from gym4real.results.artefacts import trainer_of
from gym4real.results.claims import check_claim, identical, on_trainer, quantity_scores

#: Thresholds of the performance profile.
PROFILE_POINTS = 101


def _read(episodes: pd.DataFrame, column: str = "objective") -> tuple[dict[str, np.ndarray], dict[str, list[int]]]:
    """The score matrices and training seeds of ``episodes.csv`` (:func:`gym4real.bench.episodes.score_matrices`)."""
    return score_matrices(episodes, "episodes.csv", column)


def identical_to(scores: dict[str, np.ndarray]) -> dict[str, str]:
    """Policy -> the first earlier policy with the same score in every test episode (and every seed)."""
    found: dict[str, str] = {}
    names = list(scores)
    for i, name in enumerate(names):
        same = [other for other in names[:i] if other not in found and identical(scores[name], scores[other])]
        if same:
            found[name] = same[0]
    return found


def summary(episodes: pd.DataFrame) -> pd.DataFrame:
    """``summary.csv``: per policy, IQM [95 % interval] of the objective, mean, spread, mean return."""
    scores, seeds = _read(episodes)
    returns, _ = _read(episodes, "return")
    same = identical_to(scores)
    rows = []
    for name, matrix in scores.items():
        value, low, high = stats.iqm_ci(matrix, bool(seeds[name]))
        rows.append(
            {
                "policy": name,
                "kind": "agent" if seeds[name] else "baseline",
                "seeds": len(seeds[name]),
                "episodes": matrix.shape[1],
                "iqm": value,
                "low": low,
                "high": high,
                "mean": float(matrix.mean()),
                "spread": float(stats.batched("spread")(matrix[None])[0]),
                "mean_return": float(returns[name].mean()),
                "identical_to": same.get(name, ""),
            }
        )
    return pd.DataFrame(rows)


def per_seed(episodes: pd.DataFrame, runs: pd.DataFrame | None) -> pd.DataFrame:
    """Per trained policy and seed: IQM and mean over test episodes, and the run's validation-selected checkpoint."""
    scores, seeds = _read(episodes)
    rows = []
    for name in [n for n in scores if seeds[n]]:
        iqms, means = stats.per_seed(scores[name])
        for seed, iqm, mean in zip(seeds[name], iqms, means, strict=True):
            row: dict[str, Any] = {"policy": name, "seed": int(seed), "iqm": float(iqm), "mean": float(mean)}
            if runs is not None:
                run = runs[(runs["algo"] == name) & (runs["seed"] == int(seed))]
                if len(run):
                    row["selected_at"] = run["selected_at"].iloc[0]
                    row["selected_unit"] = run["selected_unit"].iloc[0]
            rows.append(row)
    return pd.DataFrame(rows)


def improvement(episodes: pd.DataFrame) -> pd.DataFrame:
    """``improvement.csv``: P(agent > baseline) with its 95 % interval, per RL algorithm and baseline."""
    scores, seeds = _read(episodes)
    rows = []
    for agent in [n for n in scores if seeds[n]]:
        for base in [n for n in scores if not seeds[n]]:
            p, low, high = stats.probability_of_improvement(scores[agent], scores[base], True, False)
            rows.append({"agent": agent, "baseline": base, "p": p, "low": low, "high": high})
    return pd.DataFrame(rows, columns=["agent", "baseline", "p", "low", "high"])


def check_claims(
    env_id: str, budget: str, episodes: pd.DataFrame, trainer: str, bootstrap_seed: int = 0
) -> list[dict[str, Any]]:
    """Every claim the env's protocol declares, checked on the scores of ``episodes`` (each on its quantity).

    ``trainer`` trained the section's agents (:func:`~gym4real.results.artefacts.trainer_of` its folder): in a
    section of a trainer other than SB3 each claim is checked on that trainer's PPO agent in place of ``ppo``
    (:func:`~gym4real.results.claims.on_trainer`; ``ppo-jax`` for the JAX trainer), and its record names the
    trainer (``trainer``). A claim whose policy has no rows in ``episodes`` is ``not checked``.

    A claim about an agent whose every seed scores as a baseline in every test episode (:func:`identical`)
    records that baseline (``identical_to``): the agent learned nothing the baseline does not do.

    ``bootstrap_seed`` seeds every interval (the published verdicts: 0; another seed shows how much the ends move).
    """
    from gym4real.bench.benchmark import protocol

    scores, seeds = _read(episodes)
    trained = {n for n in scores if seeds[n]}
    learned = {
        agent: same
        for agent in trained
        if (same := next((b for b in scores if b not in trained and identical(scores[agent], scores[b])), None))
    }
    records = []
    for claim in (on_trainer(c, trainer) for c in protocol(env_id).claims):
        own = scores if claim.quantity == "objective" else quantity_scores(episodes, claim.quantity)
        beside = None if claim.quantity == "objective" else scores
        record = check_claim(claim, own, trained, seeds.get(claim.policy) or None, beside, bootstrap_seed)
        if claim.policy in learned:  # every seed plays a baseline's episodes: the verdict is about that baseline
            record["identical_to"] = learned[claim.policy]
        records.append(
            {"env_id": env_id, "budget": budget, **record, **({} if trainer == "sb3" else {"trainer": trainer})}
        )
    return records


def profile_figure(episodes: pd.DataFrame, path: Path, title: str) -> None:
    """``performance_profile.png``: per policy, the fraction of its (run, episode) scores above each score.

    ``title``: the env id (an upper reference is labelled with its kind).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from gym4real.bench.plots import LINESTYLES, MARKERS
    from gym4real.bench.upper_label import label

    scores, seeds = _read(episodes)
    same = identical_to(scores)
    every = np.concatenate([m.ravel() for m in scores.values()])
    tau = np.linspace(every.min(), every.max(), PROFILE_POINTS)
    fig, ax = plt.subplots(figsize=(8.5, 4.2))
    for i, (name, matrix) in enumerate(scores.items()):
        point, low, high = stats.profile_band(matrix, bool(seeds[name]), tau)
        (line,) = ax.step(
            tau,
            point,
            where="post",
            label=f"{label(title, name)} (identical to {same[name]})" if name in same else label(title, name),
            linestyle=LINESTYLES[i % len(LINESTYLES)],
            marker=MARKERS[i % len(MARKERS)],
            markersize=4,
            markevery=(i * 3 % 10, 10),
        )
        ax.fill_between(tau, low, high, step="post", color=line.get_color(), alpha=0.12, linewidth=0)
    ax.set(xlabel="score τ (per-episode objective)", ylabel="fraction of runs x episodes with score > τ")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title(f"{title}: performance profile (95 % band)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def analyse(folder: Path, env_id: str, budget: str) -> list[dict[str, Any]]:
    """Write ``summary.csv``, ``improvement.csv``, ``claims.json`` and the profile figure from ``episodes.csv``.

    The claims are checked on the agents of the folder's trainer (:func:`~gym4real.results.artefacts.trainer_of`).
    """
    episodes = pd.read_csv(folder / "episodes.csv")
    summary(episodes).to_csv(folder / "summary.csv", index=False)
    improvement(episodes).to_csv(folder / "improvement.csv", index=False)
    claims = check_claims(env_id, budget, episodes, trainer_of(folder.name))
    (folder / "claims.json").write_text(json.dumps(claims, indent=1))
    profile_figure(episodes, folder / "performance_profile.png", env_id)
    return claims


def recheck(folder: Path) -> list[dict[str, Any]]:
    """Decide a published section's claims again from its ``episodes.csv`` under the current rules, no training.

    Rewrites ``claims.json`` (env and budget from ``report.json``, the trainer from the folder's name) and, where
    the section has ``placements.csv``, its workspace heat map; ``results_page.write_page(page, page)`` then
    renders the page from these files.
    """
    from gym4real.results import workspace

    report = json.loads((folder / "report.json").read_text())
    episodes = pd.read_csv(folder / "episodes.csv")
    claims = check_claims(report["env_id"], report["budget"], episodes, trainer_of(folder.name))
    (folder / "claims.json").write_text(json.dumps(claims, indent=1))
    workspace.heatmap_figure(folder, report["env_id"])
    return claims
