"""The paper's two benchmark figures, drawn headless with matplotlib.

Both plot the protocol's objective (the score; the return where the protocol names none), the policies
best first by its IQM (:meth:`~gym4real.bench.benchmark.BenchmarkResult.ranking`), and their titles say
which episodes they show. A non-causal upper reference (``hindsight``, ``oracle``:
:func:`~gym4real.core.registry.non_causal`) is never ranked among them: it comes last, drawn in black with
its own marker (:data:`UPPER_MARKER`) and labelled with its kind
(``hindsight (non-causal upper reference, exact)``: :func:`~gym4real.bench.upper_reference.label`).

Policies are drawn by their short labels; each line has its own line style and
marker, the markers at staggered steps so that lines which coincide stay visible, and a policy whose mean
curve hides an earlier one's says so in the legend (``p79 (overlaps p78)``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gym4real.bench import stats
from gym4real.core.registry import non_causal

if TYPE_CHECKING:
    from gym4real.bench.benchmark import BenchmarkResult

MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "*")
LINESTYLES = ("-", "--", "-.", ":")
#: The marker and colour of a non-causal upper reference, which no baseline or agent is drawn with.
UPPER_MARKER = "*"
UPPER_COLOUR = "black"


def upper_references(result: BenchmarkResult) -> list[str]:
    """The result's non-causal upper references (``hindsight``, ``oracle``), best first."""
    upper = set(non_causal(result.env_id))
    return [name for name in result.ranking() if name in upper]


def plotted_order(result: BenchmarkResult) -> list[str]:
    """The policies as the figures show them: the ranked ones best first, then the upper references."""
    upper = upper_references(result)
    return [name for name in result.ranking() if name not in upper] + upper


def mean_curves(result: BenchmarkResult) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Policy (best first, upper references last) -> mean cumulative objective per step with its 95 % band."""
    return {
        name: stats.mean_band([np.cumsum(r) for r in result.objective_steps(name)]) for name in plotted_order(result)
    }


def objective_label(result: BenchmarkResult) -> str:
    """The objective for an axis: ``objective (deficit + overflow + starving)`` or ``objective (= return)``."""
    return "objective (= return)" if result.objective_is_return else f"objective ({result.objective_name})"


def episodes_label(result: BenchmarkResult) -> str:
    """The episodes a figure shows: ``13 test episodes`` or ``3 seeded episodes (not the test protocol)``."""
    n = len(result.episodes)
    return f"{n} test episodes" if result.test_protocol else f"{n} episodes, not the test protocol"


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


def figure_labels(result: BenchmarkResult) -> dict[str, str]:
    """Policy -> its label in the figures: the short label, an upper reference's with its kind."""
    from gym4real.bench.upper_label import label

    upper = set(upper_references(result))
    return {n: label(result.env_id, n) if n in upper else short for n, short in result.labels.items()}


def legend_labels(
    result: BenchmarkResult, curves: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
) -> dict[str, str]:
    """Policy -> its legend entry: its figure label, and ``(overlaps other)`` when its curve hides another's."""
    labels, hidden = figure_labels(result), overlapping(curves)
    return {n: f"{labels[n]} (overlaps {labels[hidden[n]]})" if n in hidden else labels[n] for n in curves}


def save_figures(result: BenchmarkResult, out: Path) -> list[Path]:
    """Write ``cumulative_reward.png`` (mean cumulative objective with a 95 % band) and ``returns_boxplot.png``.

    Both plot the objective, the score claims are checked on and policies ranked by (the return where the
    protocol names no objective); the file names are kept for the pages that link them.

    Args:
        result: The benchmark's result.
        out: The folder.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = [out / "cumulative_reward.png", out / "returns_boxplot.png"]
    what = objective_label(result)
    shown = episodes_label(result)
    curves = mean_curves(result)
    legend = legend_labels(result, curves)
    upper = upper_references(result)
    fig, ax = plt.subplots(figsize=(8.5, 4.2))
    n = len(curves)
    for i, (name, (mean, low, high)) in enumerate(curves.items()):
        steps = np.arange(1, len(mean) + 1)
        every = max(1, len(steps) // 8)
        style: dict[str, Any] = (
            {"color": UPPER_COLOUR, "linestyle": (0, (1, 1)), "marker": UPPER_MARKER, "markersize": 8}
            if name in upper
            else {"linestyle": LINESTYLES[i % len(LINESTYLES)], "marker": MARKERS[i % len(MARKERS)], "markersize": 5}
        )
        (line,) = ax.plot(steps, mean, label=legend[name], markevery=(i * every // max(n, 1), every), **style)
        ax.fill_between(steps, low, high, color=line.get_color(), alpha=0.12, linewidth=0)
        for edge in (low, high):  # the band's edges, so that overlapping bands stay apart
            ax.plot(steps, edge, color=line.get_color(), linewidth=0.6, alpha=0.7)
    ax.set(xlabel=result.step_unit, ylabel=f"cumulative {what}")
    ax.set_title(f"{result.env_id}: mean cumulative objective, {shown} (95 % band)")
    ax.legend(
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        borderaxespad=0.0,
        frameon=False,
        title=f"best first (IQM){'; upper reference last' if upper else ''}",
    )
    fig.tight_layout()
    fig.savefig(paths[0], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(max(7.0, 1.3 * n), 4.2))
    labels = figure_labels(result)
    ranked = plotted_order(result)
    # an upper reference's tick: its name, then its mark and kind on lines of their own
    ticks = [labels[n].replace(" (", "\n(", 1).replace(", ", ",\n", 1) if n in upper else labels[n] for n in ranked]
    boxes = ax.boxplot([result.objective_values(name) for name in ranked], tick_labels=ticks, patch_artist=True)
    for name, box, median in zip(ranked, boxes["boxes"], boxes["medians"], strict=True):
        box.set_facecolor("0.85" if name in upper else "white")
        if name in upper:
            box.set_hatch("//")
            median.set_color(UPPER_COLOUR)
    if upper:
        ax.axvline(len(ranked) - len(upper) + 0.5, color="0.5", linestyle=":", linewidth=1)
    xlabel = "policy (best first by IQM" + ("; the non-causal upper reference last, not ranked)" if upper else ")")
    ax.set(xlabel=xlabel, ylabel=f"episode {what}")
    ax.set_title(f"{result.env_id}: episode objective per policy, {shown}")
    if any(len(labels[name]) > 14 for name in ranked if name not in upper):
        ax.tick_params(axis="x", labelrotation=20)
    fig.tight_layout()
    fig.savefig(paths[1], dpi=120)
    plt.close(fig)
    return paths
