"""The results page's headroom table: per env and paper agent, how far it is from the upper reference.

Read from each paper section's ``episodes.csv`` (``gym4real reproduce`` runs the env's non-causal upper
references beside its baselines). Each row names the upper reference, its IQM and its kind as the domain
declares it (``BaselineSpec.bound``: exact, heuristic with its measured gap, or not a bound), the agent, the
best rule-based baseline, and for an upper reference that is a bound: the headroom (upper reference minus
the agent) with its two-level bootstrap interval (:func:`gym4real.bench.upper_reference.headroom`), the share
of the headroom the agent closed, ``(agent - random) / (upper - random)`` with its interval
(:func:`gym4real.bench.upper_reference.headroom_closed`), and where the upper reference sits on the suite
scale (0 = ``random``, 1 = the best rule-based baseline). A row whose upper reference is not a bound has no
headroom and no share: an agent can score more than it.

Where a section also holds the causal model-predictive baseline ``mpc`` (the upper reference's planner on
forecasts), the headroom of the best paper agent is split in two
(:func:`gym4real.bench.upper_reference.headroom_split`): the **forecast headroom** (upper reference minus ``mpc``:
what better forecasts could give) and the **learning headroom** (``mpc`` minus the agent, where it is positive: what
a better learner could give).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gym4real.bench.numbers import human

if TYPE_CHECKING:
    import numpy as np

    from gym4real.results.results_page import Section

#: The columns of the table of the headroom split at ``mpc``.
SPLIT_HEADER = (
    "| env | upper reference | `mpc` (causal) | best agent | forecast headroom: upper reference - `mpc` [95 % CI] "
    "| learning headroom: `mpc` - agent, where positive [95 % CI] |"
)

#: The columns of the headroom table.
HEADER = (
    "| env | upper reference | kind | agent | best rule-based | headroom [95 % CI] | share of the headroom closed "
    "[95 % CI] | upper reference on the scale |"
)


def _num(value: float) -> str:
    return human(value)


def _share(value: float) -> str:
    return f"{human(100 * value)} %"


def _room(room: dict[str, float]) -> str:
    """A headroom with its interval, written for people (:func:`~gym4real.bench.numbers.human`)."""
    from gym4real.bench.numbers import human, human_interval

    return f"{human(room['shortfall'])} {human_interval(room['low'], room['high'])}"


def _learning(room: dict[str, float], agent: str) -> str:
    """The learning headroom's cell: ``mpc`` minus the agent with its interval, or none where the agent is ahead."""
    cell = _room(room)
    if room["shortfall"] > 0:
        return cell
    return f"none: `{agent}` scores at least `mpc` (`mpc` - agent {cell})"


def split_rows(name: str, upper: str, scores: dict[str, np.ndarray], agents: list[str]) -> list[str]:
    """The rows of the headroom split of one env: its best agent's forecast and learning headroom at ``mpc``.

    Args:
        name: The env's name.
        upper: Its upper reference (a bound) measured in the section.
        scores: Policy -> ``(runs, episodes)`` objective matrix of the section (with ``mpc`` and ``upper``).
        agents: The section's trained agents (none: no row).
    """
    from gym4real.bench import stats
    from gym4real.bench.numbers import human
    from gym4real.bench.upper_reference import MPC, headroom_split

    if MPC not in scores or not agents:
        return []
    best = max(agents, key=lambda a: stats.iqm(scores[a]))
    split = headroom_split(scores[upper], scores[MPC], scores[best])
    return [
        f"| `{name}` | `{upper}` {human(stats.iqm(scores[upper]))} | {human(stats.iqm(scores[MPC]))} "
        f"| `{best}` {human(stats.iqm(scores[best]))} | {_room(split['forecast'])} "
        f"| {_learning(split['learning'], best)} |"
    ]


def headroom_table(sections: list[Section]) -> list[str]:
    """The page's headroom section (empty when no env of the page has an upper reference)."""
    from gym4real.bench import stats, suite_score, upper_reference
    from gym4real.bench.benchmark import protocol
    from gym4real.bench.episodes import score_matrices
    from gym4real.core.registry import non_causal
    from gym4real.core.registry import upper_reference as spec_of

    rows: list[str] = []
    split: list[str] = []
    for section in sections:
        env_id = section.report["env_id"]
        upper = non_causal(env_id)
        if section.budget != "paper" or not upper:
            continue
        scores, seeds = score_matrices(section.episodes, section.name)
        name = env_id.split("/", 1)[-1]
        measured = [u for u in upper if u in scores]
        if not measured:
            rows.append(
                f"| `{name}` | not measured in this section (`gym4real bench {env_id} --policies {upper[0]}`) "
                "| | | | | | |"
            )
            continue
        spec = protocol(env_id)
        baselines = {p: m for p, m in scores.items() if not seeds[p]}
        scale = suite_score.scale(env_id, baselines, spec.rule_based)
        agents = sorted(p for p in scores if seeds[p])
        best_rule = f"`{scale.best}` {_num(scale.top)}" if scale.best else "-"
        for u in measured:
            kind = spec_of(env_id, u)
            if kind.is_bound:
                split += split_rows(name, u, scores, agents)
            top = stats.iqm(scores[u])
            on_scale = f"{_num(float(scale.normalise(top)))}" if scale.usable and kind.is_bound else "-"
            head = f"| `{name}` | `{u}` {_num(top)} | {kind.bound_words()} |"
            for i, agent in enumerate(agents or [None]):
                cells = [f"`{agent}` {_num(stats.iqm(scores[agent]))}" if agent else "-", best_rule]
                if agent is None or not kind.is_bound:
                    cells += ["-" if kind.is_bound else "- (not a bound)", "-", on_scale]
                else:
                    room = upper_reference.headroom(scores[u], scores[agent])
                    cells.append(f"{_num(room['shortfall'])} [{_num(room['low'])}, {_num(room['high'])}]")
                    if "random" in baselines:
                        closed = upper_reference.headroom_closed(scores[u], baselines["random"], scores[agent])
                        cells.append(f"{_share(closed['share'])} [{_share(closed['low'])}, {_share(closed['high'])}]")
                    else:
                        cells.append("- (no `random`)")
                    cells.append(on_scale)
                rows.append((head if i == 0 else "| | | |") + " " + " | ".join(cells) + " |")
    if not rows:
        return []
    return [
        "## Headroom: how far from optimal?",
        "",
        "The upper references are non-causal: each is handed the test episode's exogenous data (or the simulator's "
        "ground truth) and plans or acts with it (see *How far from optimal?*). Each is labelled by its kind, as its "
        "domain declares it: **exact** (proven optimal: no controller can score more on an episode), **heuristic** "
        "(a plan, not proven optimal: a further search found at most the stated gap more on a test episode) or "
        "**not a bound** (a controller can score more: no headroom is measured to it). IQMs of the per-episode "
        "objective, every paper agent (all seeds pooled); headroom = upper reference minus the agent, with its 95 % "
        "two-level bootstrap interval; the share of the headroom closed is (agent - `random`) / (upper reference - "
        "`random`), the suite scale with the optimum as its 1; the last column places the upper reference on the "
        "suite scale (0 = `random`, 1 = the best rule-based baseline).",
        "",
        HEADER,
        "|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        *(
            [
                "### Forecast and learning headroom",
                "",
                "Where a section holds the causal model-predictive baseline `mpc` (the upper reference's planner run "
                "on forecasts of what the upper reference is handed, replanned as the episode unfolds), the best paper "
                "agent's headroom splits in two: the **forecast headroom**, upper reference minus `mpc`, what better "
                "forecasts could give; and the **learning headroom**, `mpc` minus the agent where it is positive, what "
                "a better learner could give (none where the agent scores at least `mpc`). IQMs of the per-episode "
                "objective; the two add up to the agent's headroom above. Intervals: 95 % percentile bootstrap, the "
                "test episodes resampled (paired across the policies) and, for the learning headroom, the agent's "
                "training seeds as well; the forecast headroom compares two baselines, so only the episodes are "
                "resampled.",
                "",
                SPLIT_HEADER,
                "|---|---|---|---|---|---|",
                *split,
                "",
            ]
            if split
            else []
        ),
    ]
