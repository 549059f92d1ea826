"""Every claim of the paper that a protocol declares, held to the paper's own sentence, section and list.

The table quotes the paper (``gym4real-paper.tex``, main text, Sec. 2): the sentence that makes each claim,
the sentence that names the policies it compares with, and the section. A claim's text, section, quantity,
relation and compared policies must follow it; a check of this suite's own is marked as not the paper's.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from gym4real.core.registry import registry

PAPER = Path(os.environ.get("GYM4REAL_PAPER", "/work/shared/paper/gym4real-paper.tex"))

#: (env id, policy, relation) -> section, quantity, compared policies, consistently, claim sentence, list sentence.
PAPER_CLAIMS: dict[tuple[str, str, str], dict] = {
    ("gym4real/dam-v0", "ppo", "above"): {
        "section": "2.1",
        "quantity": "objective",
        "others": ("random", "mean", "max", "ead"),
        "consistently": False,
        "claim": "highlight the capability of the PPO agent to perform better than rule-based strategies",
        "list": r"four rule-based baselines: the \textit{Random} policy",
    },
    ("gym4real/elevator-v0", "qlearning", "above"): {
        "section": "2.2",
        "quantity": "objective",
        "others": ("random", "longest_first", "shortest_first"),
        "consistently": True,
        "claim": "both RL algorithms consistently outperform the other rule-based solutions",
        "list": r"different rule-based strategies, i.e., the \emph{Random} policy, and the \textit{Longest-First} "
        r"(LF) and the \textit{Shortest-First} (SF) policies",
    },
    ("gym4real/elevator-v0", "sarsa", "above"): {
        "section": "2.2",
        "quantity": "objective",
        "others": ("random", "longest_first", "shortest_first"),
        "consistently": True,
        "claim": "both RL algorithms consistently outperform the other rule-based solutions",
        "list": r"different rule-based strategies, i.e., the \emph{Random} policy, and the \textit{Longest-First} "
        r"(LF) and the \textit{Shortest-First} (SF) policies",
    },
    ("gym4real/elevator-v0", "qlearning", "above", "sarsa"): {
        "section": "2.2",
        "quantity": "objective",
        "others": ("sarsa",),
        "consistently": False,
        "claim": "Q-Learning shows higher performance than SARSA",
        "list": "Q-Learning shows higher performance than SARSA",
    },
    ("gym4real/microgrid-v0", "ppo", "above"): {
        "section": "2.3",
        "quantity": "objective",
        "others": ("random", "only_market", "battery_first", "fifty_fifty"),
        "consistently": False,
        "claim": "PPO achieves higher profit than rule-based strategies",
        "list": r"the \textit{Random} policy; the \textit{Only-market} (OM) policy",
    },
    ("gym4real/robofeeder-picking-v0", "ppo", "above"): {
        "section": "2.4.1",
        "quantity": "success",
        "others": ("fixed",),
        "consistently": False,
        "claim": "the PPO agent achieves higher and more evenly distributed success rates",
        "list": r"against a fixed action rule-based strategy on the \texttt{picking-v0} environment",
    },
    ("gym4real/robofeeder-planning-v0", "ppo", "above"): {
        "section": "2.4.2",
        "quantity": "objective",
        "others": ("random",),
        "consistently": False,
        "claim": "we compare the efficiency of a trained PPO~\\cite{schulman2017ppo} agent against a "
        "\\textit{Random} strategy",
        "list": r"against a \textit{Random} strategy",
    },
    **{
        ("gym4real/trading-v0", algo, "not_above"): {
            "section": "2.5",
            "quantity": "objective",
            "others": ("buy_and_hold", "sell_and_hold"),
            "consistently": True,
            "claim": "neither PPO nor DQN is able to consistently outperform the baselines",
            "list": r"against common passive baselines, B\&H and S\&H",
        }
        for algo in ("ppo", "dqn")
    },
    **{
        ("gym4real/trading-v0", algo, "less_variable"): {
            "section": "2.5",
            "quantity": "objective",
            "others": ("buy_and_hold", "sell_and_hold"),  # the sentence names none: its figure's baselines
            "consistently": False,
            "claim": "it significantly reduces the daily variability of the P\\&L",
            "list": r"against common passive baselines, B\&H and S\&H",
        }
        for algo in ("ppo", "dqn")
    },
    ("gym4real/wds-v0", "dqn", "above"): {
        "section": "2.6",
        "quantity": "objective",
        "others": ("random", "p78", "p79", "default"),
        "consistently": False,
        "claim": "DQN achieves a higher level of resilience with respect to other baselines",
        "list": r"different rule-based baselines: the \textit{Random} policy, \textit{P78} and \textit{P79} policies",
    },
    ("gym4real/wds-v0", "dqn", "less_variable"): {
        "section": "2.6",
        "quantity": "objective",
        "others": ("random", "p78", "p79", "default"),  # the sentence names none: its figure's baselines
        "consistently": False,
        "claim": "it has a more consistent behavior and low variance",
        "list": r"different rule-based baselines: the \textit{Random} policy, \textit{P78} and \textit{P79} policies",
    },
}

#: The section headings of the paper's Sec. 2, in order (2.1 ... 2.6; 2.4.1 and 2.4.2 under 2.4).
SECTIONS = {
    "2.1": r"\subsection{\texttt{DamEnv}}",
    "2.2": r"\subsection{\texttt{ElevatorEnv}}",
    "2.3": r"\subsection{\texttt{MicrogridEnv}}",
    "2.4.1": r"\subsubsection{\texttt{RoboFeeder-picking}}",
    "2.4.2": r"\subsubsection{\texttt{RoboFeeder-planning}}",
    "2.5": r"\subsection{\texttt{TradingEnv}}",
    "2.6": r"\subsection{\texttt{WaterDistributionSystemEnv}}",
}


def _key(env_id: str, claim) -> tuple:
    key = (env_id, claim.policy, claim.relation)
    return (*key, claim.others[0]) if claim.others == ("sarsa",) else key


def _declared() -> list[tuple]:
    return [(env_id, c) for env_id, spec in registry().benchmarks.items() for c in spec.claims]


def test_every_paper_claim_follows_the_papers_sentence_section_quantity_and_list() -> None:
    declared = _declared()
    paper = {_key(env_id, c): (env_id, c) for env_id, c in declared if c.paper}
    assert len(paper) == sum(c.paper for _, c in declared)  # no two claims of the paper under one key
    assert set(paper) == set(PAPER_CLAIMS)  # 13 claims of the paper, none left out, none made up
    for key, quoted in PAPER_CLAIMS.items():
        _, claim = paper[key]
        assert claim.section == quoted["section"] and f"(Sec. {quoted['section']}" in claim.text, key
        assert claim.quantity == quoted["quantity"], key
        assert claim.others == quoted["others"], key
        assert claim.consistently == quoted["consistently"], key
        assert ("consistently" in claim.text) == quoted["consistently"], key
    assert "follows no rule" not in " ".join(c.text for _, c in declared)


#: The suite's own checks: (env id, policy, relation, compared policies, quantity).
OWN_CHECKS = [
    ("gym4real/dam-v0", "ppo", "above", ("mpc",), "objective"),
    ("gym4real/microgrid-v0", "ppo", "above", ("mpc",), "objective"),
    ("gym4real/robofeeder-picking-v1", "ppo", "above", ("fixed",), "success"),
    ("gym4real/wds-v0", "dqn", "above", ("mpc",), "objective"),
]


def test_the_suites_own_checks_are_marked_and_say_the_paper_does_not_make_them() -> None:
    own = [(env_id, c) for env_id, c in _declared() if not c.paper]
    assert sorted((e, c.policy, c.relation, c.others, c.quantity) for e, c in own) == OWN_CHECKS
    for _, claim in own:
        assert "own check" in claim.text and not claim.section


@pytest.mark.skipif(not PAPER.is_file(), reason="the paper's source is not here (set GYM4REAL_PAPER)")
def test_the_table_quotes_the_paper_in_the_section_it_names() -> None:
    text = PAPER.read_text(encoding="utf-8")
    main = text[text.index(r"\section{Environments and Benchmarking}") : text.index(r"\section{Discussion")]
    starts = {number: main.index(heading) for number, heading in SECTIONS.items()}
    ends = {n: min([s for s in starts.values() if s > starts[n]] + [len(main)]) for n in starts}
    flat = {n: re.sub(r"\s+", " ", main[starts[n] : ends[n]]) for n in starts}
    for key, quoted in PAPER_CLAIMS.items():
        assert quoted["claim"] in flat[quoted["section"]], key
        assert quoted["list"] in flat[quoted["section"]], key
