"""The figures and the Markdown report of ``gym4real evaluate`` (:class:`~gym4real.bench.evaluate.Evaluation`).

``aggregate_intervals.png``: per policy, the suite IQM and the shortfall below the best rule with their 95 %
intervals, in rliable's style (one row per policy, a bar for the interval, a marker at the estimate: a
zero-width interval is its marker alone); the axes hold every bound and estimate, and your agents are drawn
apart (their own colour, a larger diamond, their label in bold and marked "your agent").
``performance_profile.png``: the fraction of runs above each normalised score, with its 95 % band.
``report.md``: the tables and figures, for a paper to link.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from gym4real.bench import suite_score
from gym4real.core.registry import slug

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from gym4real.bench.evaluate import Evaluation

#: The two panels of ``aggregate_intervals.png``: the key of the estimate, of its bounds, the title and the x label.
PANELS = (
    ("iqm", "low", "high", "IQM (normalised)", "normalised score (0 = random, 1 = best rule)"),
    (
        "shortfall",
        "shortfall_low",
        "shortfall_high",
        "shortfall below the best rule",
        "mean shortfall of the runs below 1",
    ),
)
#: The colour of your agents (the reference agents take the others of the cycle).
AGENT_COLOUR = "#d62728"  # C3 of matplotlib's default cycle, which the other policies skip


def _policies(evaluation: Evaluation) -> list[str]:
    return [p for p in [*evaluation.agents, *evaluation.references()] if evaluation.runs(p)]


def colours(policies: list[str], agents: list[str]) -> dict[str, str]:
    """Policy -> its colour in both figures: your agents :data:`AGENT_COLOUR`, the others the rest of the cycle."""
    others = iter(f"C{i}" for i in range(10) if f"C{i}" != "C3")
    return {p: AGENT_COLOUR if p in agents else next(others, "grey") for p in policies}


def draw_intervals(ax: Axes, rows: list[tuple[float, float, float]], colours: list[str], mine: list[bool]) -> None:
    """One row per policy: a bar from low to high and a marker at the estimate, the axes holding every point.

    A zero-width interval is its marker alone; a row of ``mine`` (your agent) gets a larger diamond.
    """
    for row, ((estimate, low, high), colour, own) in enumerate(zip(rows, colours, mine, strict=True)):
        if high > low:
            ax.hlines(row, low, high, color=colour, linewidth=9, alpha=0.45)
        ax.plot(
            [estimate],
            [row],
            linestyle="none",
            marker="D" if own else "o",
            markersize=10 if own else 7,
            color=colour,
            markeredgecolor="black",
            zorder=3,
            label="your agent" if own else None,
        )
    points = [v for row in rows for v in row]
    low, high = min(points), max(points)
    pad = 0.08 * (high - low) if high > low else max(0.05, 0.05 * abs(high))
    ax.set_xlim(low - pad, high + pad)
    ax.set_ylim(-0.6, len(rows) - 0.4)


def aggregate_figure(aggregates: dict[str, dict[str, Any]], agents: list[str]) -> Figure:
    """The figure of ``aggregate_intervals.png`` from each policy's :func:`suite_score.summary` (agents first)."""
    import matplotlib.pyplot as plt

    policies = list(aggregates)
    mine = [p in agents for p in policies]
    drawn = list(colours(policies, agents).values())
    fig, axes = plt.subplots(1, 2, figsize=(10, 0.5 * len(policies) + 1.7), sharey=True)
    for ax, (key, low, high, title, xlabel) in zip(axes, PANELS, strict=True):
        rows = [(aggregates[p][key], aggregates[p][low], aggregates[p][high]) for p in policies]
        draw_intervals(ax, rows, drawn, mine)
        ax.set(title=title, xlabel=xlabel)
        ax.grid(axis="x", alpha=0.3)
    names = [f"{p} (your agent)" if own else p for p, own in zip(policies, mine, strict=True)]
    axes[0].set_yticks(range(len(policies)), names)
    for label, own in zip(axes[0].get_yticklabels(), mine, strict=True):
        label.set_fontweight("bold" if own else "normal")
    axes[0].invert_yaxis()  # the first policy (your agent) on top
    fig.tight_layout()
    return fig


def figures(evaluation: Evaluation, out: Path) -> list[Path]:
    """Draw the aggregate intervals and the performance profile into ``out``; return their paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    policies = _policies(evaluation)
    if not policies:
        return []
    written = [out / "aggregate_intervals.png", out / "performance_profile.png"]
    fig = aggregate_figure({p: evaluation.aggregate(p) for p in policies}, evaluation.agents)
    fig.savefig(written[0], dpi=100)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(7, 4))
    palette = colours(policies, evaluation.agents)
    for policy in policies:
        colour = palette[policy]
        profile, low, high = suite_score.suite_profile(evaluation.runs(policy), suite_score.THRESHOLDS)
        ax.plot(suite_score.THRESHOLDS, profile, color=colour, label=policy)
        ax.fill_between(suite_score.THRESHOLDS, low, high, color=colour, alpha=0.2)
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
    envs = list(evaluation.envs)
    lines = [
        "# Evaluation on the gym4real test protocols",
        "",
        "Normalised score: 0 = the `random` baseline, 1 = the best rule-based baseline of the environment (IQMs of "
        "the per-episode objective over its test protocol). A run (one training seed on one environment) scores the "
        "IQM of its normalised episodes; the suite "
        "IQM is over all runs, with a 95 % stratified two-level bootstrap interval (within each environment, the "
        "seeds and the test episodes resampled); the shortfall below the best rule is the mean shortfall of the runs "
        "below 1 (rliable's optimality gap with the best rule as the target: the scale does not reach the optimum, "
        "which each environment's upper reference measures below). An environment enters the suite score only when "
        "its 1 beats its 0 with a 95 % interval of their IQM difference above 0. Policies evaluated on different "
        "environments average different environments: compare them per environment (the columns), not by the "
        "aggregate.",
        "",
        "## Suite score",
        "",
        f"| policy | kind | envs | runs | IQM | 95 % CI | shortfall below the best rule | 95 % CI | "
        f"{' | '.join(f'`{slug(e)}`' for e in envs)} |",
        "|---|---|---|---|---|---|---|---|" + "---|" * len(envs),
    ]
    for policy in [*evaluation.agents, *evaluation.references()]:
        agg = evaluation.aggregate(policy)
        kind = "agent" if policy in evaluation.agents else "reference"
        per_env = " | ".join(_num(agg["per_env"].get(e)) if agg["iqm"] is not None else "-" for e in envs)
        if agg["iqm"] is None:
            lines.append(f"| `{policy}` | {kind} | 0 | 0 | - | - | - | - | {per_env} |")
            continue
        lines.append(
            f"| `{policy}` | {kind} | {len(agg['envs'])} | {agg['runs']} | {_num(agg['iqm'])} | "
            f"[{_num(agg['low'])}, {_num(agg['high'])}] | {_num(agg['shortfall'])} | "
            f"[{_num(agg['shortfall_low'])}, {_num(agg['shortfall_high'])}] | {per_env} |"
        )
    lines += ["", *(f"![{name}]({name})" for name in figure_names), ""]
    for env_id, result in evaluation.envs.items():
        scale = result.scale
        lines += [f"## `{env_id}`", "", f"Reference runs: {result.reference}.", ""]
        words = scale.words("`")
        lines.append(words[0].upper() + words[1:] + ("." if scale.usable else "; left out of the suite score."))
        lines += [
            "",
            "| agent | seeds | objective IQM [95 % CI] | normalised IQM [95 % CI] | P(improvement) [95 % CI] "
            "| shortfall from the upper reference [95 % CI] | share of the headroom closed [95 % CI] |",
        ]
        lines.append("|---|---|---|---|---|---|---|")
        kinds: dict[str, dict[str, Any]] = {}
        for agent in evaluation.agents:
            if agent not in result.scores:
                continue
            rec = result.record(agent)
            kinds.update(rec["upper_references"])
            improvement = "; ".join(
                f"over `{o}`: {p:.3f} [{rec['probability_of_improvement_ci'][o][0]:.3f}, "
                f"{rec['probability_of_improvement_ci'][o][1]:.3f}]"
                for o, p in rec["probability_of_improvement"].items()
            )
            room = "; ".join(
                f"`{u}` (IQM {r['upper_iqm']:.5g}): {r['shortfall']:.5g} [{r['low']:.5g}, {r['high']:.5g}]"
                for u, r in rec["headroom"].items()
            )
            closed = "; ".join(
                f"`{u}`: {c['share']:.3f} [{c['low']:.3f}, {c['high']:.3f}]" for u, c in rec["headroom_closed"].items()
            )
            lines.append(
                f"| `{agent}` | {rec['seeds']} | {rec['iqm']:.5g} [{rec['iqm_low']:.5g}, {rec['iqm_high']:.5g}] | "
                f"{_num(rec['normalized_iqm'])} [{_num(rec['low'])}, {_num(rec['high'])}] | {improvement or '-'} "
                f"| {room or '-'} | {closed or '-'} |"
            )
        lines.append("")
        for upper, bound in kinds.items():
            lines += [
                f"Upper reference `{upper}`: **{bound['words']}** ({bound['note']})."
                + (
                    " It is not a bound: no shortfall or share is measured to it."
                    if bound["bound"] == "not a bound"
                    else " It is non-causal: it is handed each episode's exogenous data and plans with hindsight (see "
                    "the docs' *How far from optimal?*), so the shortfall is the headroom no causal agent is promised "
                    "to close; the share of the headroom closed is (agent - `random`) / (upper reference - `random`)."
                ),
                "",
            ]
    path = out / "report.md"
    path.write_text("\n".join(lines))
    return path
