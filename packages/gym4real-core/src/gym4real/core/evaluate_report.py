"""The figures and the Markdown report of ``gym4real evaluate`` (:class:`~gym4real.core.evaluate.Evaluation`).

``aggregate_intervals.png``: per policy, the suite IQM and optimality gap with their 95 % intervals, in
rliable's style (one row per policy, a bar for the interval, a tick at the estimate).
``performance_profile.png``: the fraction of runs above each normalised score, with its 95 % band.
``report.md``: the tables and figures, for a paper to link.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from gym4real.core import suite_score

if TYPE_CHECKING:
    from gym4real.core.evaluate import Evaluation


def _policies(evaluation: Evaluation) -> list[str]:
    return [p for p in [*evaluation.agents, *evaluation.references()] if evaluation.runs(p)]


def figures(evaluation: Evaluation, out: Path) -> list[Path]:
    """Draw the aggregate intervals and the performance profile into ``out``; return their paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    policies = _policies(evaluation)
    if not policies:
        return []
    written = [out / "aggregate_intervals.png", out / "performance_profile.png"]
    colours = {p: f"C{i}" for i, p in enumerate(policies)}
    fig, axes = plt.subplots(1, 2, figsize=(9, 0.5 * len(policies) + 1.5), sharey=True)
    for ax, (key, title) in zip(axes, (("iqm", "IQM (normalised)"), ("optimality_gap", "optimality gap")), strict=True):
        for row, policy in enumerate(policies):
            agg = evaluation.aggregate(policy)
            low, high = (
                agg["low" if key == "iqm" else "optimality_gap_low"],
                agg["high" if key == "iqm" else "optimality_gap_high"],
            )
            ax.barh(row, high - low, left=low, height=0.6, color=colours[policy], alpha=0.6)
            ax.vlines(agg[key], row - 0.3, row + 0.3, color="black")
        ax.margins(x=0.15)
        ax.set(title=title, xlabel="normalised score (0 = random, 1 = best rule-based)")
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(range(len(policies)), policies)
    fig.tight_layout()
    fig.savefig(written[0], dpi=100)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(7, 4))
    for policy in policies:
        profile, low, high = suite_score.suite_profile(list(evaluation.runs(policy).values()), suite_score.THRESHOLDS)
        ax.plot(suite_score.THRESHOLDS, profile, color=colours[policy], label=policy)
        ax.fill_between(suite_score.THRESHOLDS, low, high, color=colours[policy], alpha=0.2)
    ax.set(xlabel="normalised score tau", ylabel="fraction of runs with score > tau", title="performance profile")
    ax.axvline(1.0, color="grey", linestyle=":", linewidth=1)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(written[1], dpi=100)
    plt.close(fig)
    return written


def _num(value: Any) -> str:
    return "-" if value is None else f"{value:.3f}"


def write_report(evaluation: Evaluation, out: Path, figure_names: list[str]) -> Path:
    """Write ``report.md``: the suite scores, each environment's comparison, the figures; return its path."""
    lines = [
        "# Evaluation on the gym4real test protocols",
        "",
        "Normalised score: 0 = the `random` baseline, 1 = the best rule-based baseline of the environment (IQMs of "
        "the per-episode objective over its test protocol). A run (one training seed on one environment) scores the "
        "IQM of its normalised episodes; the suite "
        "IQM is over all runs, with a 95 % stratified bootstrap interval (seeds resampled within each environment); "
        "the optimality gap is the mean shortfall of the runs below 1.",
        "",
        "## Suite score",
        "",
        "| policy | kind | envs | runs | IQM | 95 % CI | optimality gap | 95 % CI |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for policy in [*evaluation.agents, *evaluation.references()]:
        agg = evaluation.aggregate(policy)
        kind = "agent" if policy in evaluation.agents else "reference"
        if agg["iqm"] is None:
            lines.append(f"| `{policy}` | {kind} | 0 | 0 | - | - | - | - |")
            continue
        lines.append(
            f"| `{policy}` | {kind} | {len(agg['envs'])} | {agg['runs']} | {_num(agg['iqm'])} | "
            f"[{_num(agg['low'])}, {_num(agg['high'])}] | {_num(agg['optimality_gap'])} | "
            f"[{_num(agg['optimality_gap_low'])}, {_num(agg['optimality_gap_high'])}] |"
        )
    lines += ["", *(f"![{name}]({name})" for name in figure_names), ""]
    for env_id, result in evaluation.envs.items():
        scale = result.scale
        lines += [f"## `{env_id}`", "", f"Reference runs: {result.reference}.", ""]
        lines.append(
            f"Scale: 0 = `random` ({scale.random:.6g}), 1 = `{scale.best}` ({scale.top:.6g})."
            if scale.usable
            else f"No normalised scale: {scale.note}; left out of the suite score."
        )
        lines += [
            "",
            "| agent | seeds | IQM [95 % CI] | normalised IQM [95 % CI] | P(improvement) [95 % CI] "
            "| shortfall from the upper reference [95 % CI] |",
        ]
        lines.append("|---|---|---|---|---|---|")
        for agent in evaluation.agents:
            if agent not in result.scores:
                continue
            rec = result.record(agent)
            improvement = "; ".join(
                f"over `{o}`: {p:.3f} [{rec['probability_of_improvement_ci'][o][0]:.3f}, "
                f"{rec['probability_of_improvement_ci'][o][1]:.3f}]"
                for o, p in rec["probability_of_improvement"].items()
            )
            room = "; ".join(
                f"`{u}` (IQM {r['upper_iqm']:.5g}): {r['shortfall']:.5g} [{r['low']:.5g}, {r['high']:.5g}]"
                for u, r in rec["headroom"].items()
            )
            lines.append(
                f"| `{agent}` | {rec['seeds']} | {rec['iqm']:.5g} [{rec['iqm_low']:.5g}, {rec['iqm_high']:.5g}] | "
                f"{_num(rec['normalized_iqm'])} [{_num(rec['low'])}, {_num(rec['high'])}] | {improvement or '-'} "
                f"| {room or '-'} |"
            )
        lines.append("")
        if any(k == "upper" for k in result.kinds.values()):
            lines += [
                "The upper reference is non-causal: it is handed each episode's exogenous data and plans with "
                "hindsight (see the docs' *How far from optimal?*), so the shortfall is the headroom no causal "
                "agent is promised to close.",
                "",
            ]
    path = out / "report.md"
    path.write_text("\n".join(lines))
    return path
