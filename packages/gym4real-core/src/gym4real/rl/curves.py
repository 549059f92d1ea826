"""Learning curves: evaluation returns during training, as CSV and as a PNG with a 95 % band."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from gym4real.rl.storage import write_whole


class LearningCurve:
    """Rows of (training progress, evaluation returns), written as ``curve.csv`` and drawn as ``curve.png``.

    The progress column is named by ``unit`` (``timesteps`` or ``episodes``); ``eval_episodes`` counts the
    episodes of each evaluation. Each evaluation rewrites the CSV; the figure is drawn once, when the run ends
    (:meth:`draw`): drawing it at each of a microgrid run's 100 evaluations took the training process about
    0.15 s of CPU each (more on a loaded machine).
    """

    def __init__(self, out: Path, unit: str) -> None:
        self.out = out
        self.unit = unit
        self.rows: list[dict[str, float]] = []

    def add(self, progress: int, returns: Sequence[float]) -> float:
        """Record one evaluation; return its mean."""
        x = np.asarray(returns, dtype=float)
        half = 1.96 * x.std(ddof=1) / np.sqrt(len(x)) if len(x) > 1 else 0.0
        mean = float(x.mean())
        self.rows.append(
            {
                self.unit: progress,
                "mean_return": mean,
                "ci95_low": mean - half,
                "ci95_high": mean + half,
                "eval_episodes": len(x),
            }
        )
        self.out.mkdir(parents=True, exist_ok=True)
        # whole or not at all: a run killed midway keeps the previous CSV
        write_whole(self.csv, lambda path: pd.DataFrame(self.rows).to_csv(path, index=False))
        return mean

    @classmethod
    def load(cls, out: Path, unit: str, upto: float = float("inf")) -> LearningCurve:
        """The curve written in ``out`` so far (empty when there is none): a resumed run appends to it.

        Rows past ``upto`` (the progress of the checkpoint a run resumes from) were written after it: dropped.
        """
        curve = cls(out, unit)
        if curve.csv.exists():
            curve.rows = [r for r in pd.read_csv(curve.csv).to_dict("records") if r[unit] <= upto]
        return curve

    @property
    def csv(self) -> Path:
        """Path of the CSV file."""
        return self.out / "curve.csv"

    def figure(self) -> Any:
        """The learning curve as a matplotlib figure (mean evaluation return and its 95 % band)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        frame = pd.DataFrame(self.rows)
        fig, ax = plt.subplots(figsize=(6, 3.5))
        ax.plot(frame[self.unit], frame["mean_return"], marker="o")
        ax.fill_between(frame[self.unit], frame["ci95_low"], frame["ci95_high"], alpha=0.25)
        ax.set(xlabel=self.unit, ylabel="evaluation return", title="learning curve (mean, 95 % CI)")
        fig.tight_layout()
        return fig

    def draw(self) -> None:
        """Write ``curve.png``: :meth:`figure` of the rows so far."""
        import matplotlib.pyplot as plt

        fig = self.figure()
        fig.savefig(self.out / "curve.png", dpi=110)
        plt.close(fig)
