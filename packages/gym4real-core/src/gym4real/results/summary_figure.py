"""The results page's summary figure: per env, every agent and baseline on the objective, with intervals.

One panel per env: each policy's IQM of the per-episode objective (a marker, always drawn, so that a
zero-width interval stays visible) and its 95 % two-level bootstrap interval (a bar, when it has a width),
from the section's ``summary.csv``; RL agents stand out from the baselines (red diamonds), and a non-causal
upper reference (``hindsight``, ``oracle``: :func:`~gym4real.core.registry.non_causal`) from both (a black
star below a dotted rule, labelled with its kind: exact, heuristic with its gap, not a bound); every panel's
axis spans every point and bound.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from gym4real.core.registry import MARK

#: The figure's file name, beside the page.
FILE = "summary.png"
#: The fraction of a panel's span left free on either side.
PAD = 0.06
#: How each kind of row is drawn: colour, marker, marker size, interval width.
STYLES = {
    "agent": ("C3", "D", 7, 2.2),
    "baseline": ("0.35", "o", 5, 1.6),
    "upper": ("black", "*", 10, 1.6),
}
#: Each kind of row's legend entry (baselines have none).
LEGEND = {"agent": "agent", "baseline": None, "upper": MARK}


def kinds(env_id: str, summary: pd.DataFrame) -> list[str]:
    """Each row's kind as the figure draws it: ``agent``, ``baseline`` or ``upper`` (a non-causal reference)."""
    from gym4real.core.registry import non_causal

    upper = set(non_causal(env_id))
    return [
        "upper" if policy in upper else "agent" if kind == "agent" else "baseline"
        for policy, kind in zip(summary["policy"], summary["kind"], strict=True)
    ]


def ordered(env_id: str, summary: pd.DataFrame) -> pd.DataFrame:
    """The panel's rows top to bottom: agents and baselines as given, the upper references last."""
    upper = np.array(kinds(env_id, summary)) == "upper"
    return pd.concat([summary[~upper], summary[upper]], ignore_index=True)


#: The longest y label the figure's 8 inches hold beside each panel's title; each character more widens it.
LABEL_CHARS = 20
#: Inches the figure widens per character of its longest y label beyond :data:`LABEL_CHARS`.
LABEL_INCH = 0.075


def limits(summary: pd.DataFrame) -> tuple[float, float]:
    """The x range of a panel: every IQM and bound inside, with :data:`PAD` of the span free on each side."""
    values = summary[["iqm", "low", "high"]].to_numpy(float).ravel()
    lo, hi = float(values.min()), float(values.max())
    span = hi - lo if hi > lo else max(1.0, abs(lo)) * 0.1
    return lo - PAD * span, hi + PAD * span


def _labels(env_id: str, summary: pd.DataFrame) -> list[str]:
    """The y labels of a panel: each policy, an agent marked, an upper reference with its kind."""
    from gym4real.bench.upper_label import label

    kinds = zip(summary["policy"], summary["kind"], strict=True)
    return [f"{name} (agent)" if kind == "agent" else label(env_id, name) for name, kind in kinds]


def figure(panels: list[tuple[str, str, pd.DataFrame]]) -> Any:
    """The summary figure (a matplotlib Figure), one panel per ``(env id, objective label, summary.csv)``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    from gym4real.bench.numbers import human

    shown = [(env_id, objective, ordered(env_id, s)) for env_id, objective, s in panels]  # upper references last
    heights = [0.5 + 0.32 * len(s) for _, _, s in shown]
    names = {env_id: _labels(env_id, s) for env_id, _, s in shown}
    longest = max(len(label) for labels in names.values() for label in labels)
    fig, axes = plt.subplots(
        len(panels),
        1,
        figsize=(8.0 + LABEL_INCH * max(0, longest - LABEL_CHARS), 0.9 + sum(heights)),
        squeeze=False,
        gridspec_kw={"height_ratios": heights},
        layout="constrained",
    )
    for ax, (env_id, objective, summary) in zip(axes[:, 0], shown, strict=True):
        row_kinds = kinds(env_id, summary)
        y = np.arange(len(summary))[::-1]
        for row, pos, kind in zip(summary.to_dict("records"), y, row_kinds, strict=True):
            colour, marker, size, width = STYLES[kind]
            if row["high"] > row["low"]:
                ax.hlines(pos, row["low"], row["high"], color=colour, lw=width)
            ax.plot(row["iqm"], pos, marker, color=colour, ms=size, zorder=3, label=LEGEND[kind])
        if "upper" in row_kinds:
            ax.axhline(row_kinds.count("upper") - 0.5, color="0.6", linestyle=":", lw=1)
        ax.set_yticks(y, names[env_id])
        ax.set_ylim(-0.7, len(summary) - 0.3)
        ax.set_xlim(*limits(summary))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: human(v)))
        ax.grid(axis="x", alpha=0.3)
        ax.set_title(f"{env_id}: IQM of the objective ({objective}), 95 % interval; higher is better", fontsize=9)
    fig.suptitle(
        "Every agent (red diamonds) and baseline on each env's test protocol; "
        "below the dotted rule, the non-causal upper reference (black star), not ranked",
        fontsize=10,
    )
    return fig


def write(panels: list[tuple[str, str, pd.DataFrame]], folder: Path) -> Path | None:
    """Write :data:`FILE` into ``folder`` from the panels (see :func:`figure`); None when there are none."""
    if not panels:
        return None
    import matplotlib.pyplot as plt

    fig = figure(panels)
    path = Path(folder) / FILE
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
