"""The paper's two benchmark figures, drawn headless with matplotlib.

Policies are drawn by their short labels; each line has its own line style and marker, the markers at
staggered steps so that lines which coincide stay visible, and a policy whose mean curve hides an
earlier one's says so in the legend (``p79 (overlaps p78)``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gym4real.core import stats

if TYPE_CHECKING:
    from gym4real.core.benchmark import BenchmarkResult

MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "*")
LINESTYLES = ("-", "--", "-.", ":")


def mean_curves(
    result: BenchmarkResult, objective: bool = False
) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Policy -> mean cumulative reward (or objective) per step with its 95 % band (low, high)."""
    steps = result.objective_rewards if objective else result.rewards
    return {name: stats.mean_band([np.cumsum(r) for r in eps]) for name, eps in steps.items()}


def overlapping(curves: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]], tol: float = 1e-3) -> dict[str, str]:
    """Policy -> the first earlier policy whose mean curve it hides (within ``tol`` of the figure's height)."""
    means = {name: c[0] for name, c in curves.items()}
    height = max((float(np.ptp(np.concatenate(list(means.values())))), 1e-12))
    found: dict[str, str] = {}
    names = list(means)
    for i, name in enumerate(names):
        for other in names[:i]:
            same_length = len(means[name]) == len(means[other])
            if other not in found and same_length and np.max(np.abs(means[name] - means[other])) <= tol * height:
                found[name] = other
                break
    return found


def legend_labels(
    result: BenchmarkResult, curves: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
) -> dict[str, str]:
    """Policy -> its legend entry: the short label, and ``(overlaps other)`` when its curve hides another's."""
    labels, hidden = result.labels, overlapping(curves)
    return {n: f"{labels[n]} (overlaps {labels[hidden[n]]})" if n in hidden else labels[n] for n in curves}


def save_figures(result: BenchmarkResult, out: Path, objective: bool = False) -> list[Path]:
    """Write ``cumulative_reward.png`` (mean with a 95 % band) and ``returns_boxplot.png``.

    Args:
        result: The benchmark's result.
        out: The folder.
        objective: Plot the objective (the sum of ``result.objective``'s components, the score that claims
            are checked on) instead of the full reward, when the result has one.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = [out / "cumulative_reward.png", out / "returns_boxplot.png"]
    objective = objective and bool(result.objective_rewards)
    what = f"objective ({' + '.join(result.objective)})" if objective else "reward"
    curves = mean_curves(result, objective)
    legend = legend_labels(result, curves)
    fig, ax = plt.subplots(figsize=(8.5, 4.2))
    n = len(curves)
    for i, (name, (mean, low, high)) in enumerate(curves.items()):
        steps = np.arange(1, len(mean) + 1)
        every = max(1, len(steps) // 8)
        (line,) = ax.plot(
            steps,
            mean,
            label=legend[name],
            linestyle=LINESTYLES[i % len(LINESTYLES)],
            marker=MARKERS[i % len(MARKERS)],
            markersize=5,
            markevery=(i * every // max(n, 1), every),
        )
        ax.fill_between(steps, low, high, color=line.get_color(), alpha=0.12, linewidth=0)
        for edge in (low, high):  # the band's edges, so that overlapping bands stay apart
            ax.plot(steps, edge, color=line.get_color(), linewidth=0.6, alpha=0.7)
    ax.set(xlabel=result.step_unit, ylabel=f"cumulative {what}")
    ax.set_title(f"{result.env_id}: mean cumulative {what.split(' ')[0]} (95 % CI band)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)
    fig.tight_layout()
    fig.savefig(paths[0], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(max(7.0, 1.3 * n), 4.2))
    labels = result.labels
    values = [result.objective_values(n) if objective else result.returns[n] for n in result.returns]
    ax.boxplot(values, tick_labels=[labels[name] for name in result.returns])
    per_episode = "episode objective" if objective else "episode return"
    ax.set(xlabel="policy", ylabel=per_episode, title=f"{result.env_id}: {per_episode} per policy")
    if any(len(label) > 14 for label in labels.values()):
        ax.tick_params(axis="x", labelrotation=20)
    fig.tight_layout()
    fig.savefig(paths[1], dpi=120)
    plt.close(fig)
    return paths
