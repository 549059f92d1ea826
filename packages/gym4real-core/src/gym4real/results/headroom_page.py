"""The results page's headroom table: per env, how far the best agent is from the hindsight upper reference.

Read from each paper section's ``episodes.csv`` (``gym4real reproduce`` runs the env's non-causal upper
references beside its baselines): the upper reference's IQM, the best paper agent's and the best
rule-based baseline's, the headroom (upper reference minus best agent) with its two-level bootstrap
interval (:func:`gym4real.bench.upper_reference.headroom`), and where the upper reference sits on the suite
scale (0 = ``random``, 1 = the best rule-based baseline).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gym4real.results.results_page import Section


def _num(value: float) -> str:
    return f"{value:.4g}"


def headroom_table(sections: list[Section]) -> list[str]:
    """The page's headroom section (empty when no env of the page has an upper reference)."""
    from gym4real.bench import stats, suite_score, upper_reference
    from gym4real.bench.benchmark import protocol
    from gym4real.bench.episodes import score_matrices
    from gym4real.core.registry import non_causal

    rows: list[str] = []
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
                f"| `{name}` | not measured in this section (`gym4real bench {env_id} --policies {upper[0]}`) | | | | |"
            )
            continue
        spec = protocol(env_id)
        baselines = {p: m for p, m in scores.items() if not seeds[p]}
        scale = suite_score.scale(env_id, baselines, spec.rule_based)
        agents = {p: m for p, m in scores.items() if seeds[p]}
        best_agent = max(agents, key=lambda p: stats.iqm(agents[p]), default=None)
        best_rule = f"`{scale.best}` {_num(scale.top)}" if scale.best else "-"
        for u in measured:
            top = stats.iqm(scores[u])
            on_scale = f"{_num(float(scale.normalise(top)))}" if scale.usable else "-"
            if best_agent is None:
                rows.append(f"| `{name}` | `{u}` {_num(top)} | - | {best_rule} | - | {on_scale} |")
                continue
            room = upper_reference.headroom(scores[u], agents[best_agent])
            rows.append(
                f"| `{name}` | `{u}` {_num(top)} | `{best_agent}` {_num(room['agent_iqm'])} | {best_rule} | "
                f"{_num(room['shortfall'])} [{_num(room['low'])}, {_num(room['high'])}] | {on_scale} |"
            )
    if not rows:
        return []
    return [
        "## Headroom: how far from optimal?",
        "",
        "The upper reference (`hindsight`) is non-causal: it is handed each test episode's exogenous data and plans "
        "the episode with hindsight, so it bounds what any controller could score (see *How far from optimal?*). "
        "IQMs of the per-episode objective; headroom = upper reference minus the best agent, with its 95 % two-level "
        "bootstrap interval; the last column places the upper reference on the suite scale (0 = `random`, 1 = the "
        "best rule-based baseline).",
        "",
        "| env | upper reference | best agent | best rule-based | headroom [95 % CI] | upper reference on the scale |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
    ]
