"""The paper's two benchmark figures, drawn headless with matplotlib."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gym4real.core import stats

if TYPE_CHECKING:
    from gym4real.core.benchmark import BenchmarkResult


def save_figures(result: BenchmarkResult, out: Path) -> list[Path]:
    """Write ``cumulative_reward.png`` (mean with a 95 % band) and ``returns_boxplot.png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = [out / "cumulative_reward.png", out / "returns_boxplot.png"]
    fig, ax = plt.subplots(figsize=(7, 4))
    for name, episodes in result.rewards.items():
        mean, low, high = stats.mean_band([np.cumsum(r) for r in episodes])
        steps = np.arange(1, len(mean) + 1)
        ax.plot(steps, mean, label=name)
        ax.fill_between(steps, low, high, alpha=0.25)
    ax.set(xlabel="step", ylabel="cumulative reward", title=f"{result.env_id}: mean cumulative reward (95 % CI)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(paths[0], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    names = list(result.returns)
    ax.boxplot([result.returns[n] for n in names], tick_labels=names)
    ax.set(ylabel="episode return", title=f"{result.env_id}: returns per policy")
    fig.tight_layout()
    fig.savefig(paths[1], dpi=120)
    plt.close(fig)
    return paths
