"""Every number the README and docs/headroom.md repeat from the committed results equals the results' own.

The pages are written by hand around the numbers of ``docs/results`` (each section's ``summary.csv``,
``episodes.csv`` and ``report.json``); these tests read each repeated number off the page and recompute it
from those files, to the digits the page gives, so that a page cannot disagree with the results or with
itself (issue 45: "PPO scoring 1.79 on dam" above a dam section saying 1.42).
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pandas as pd
import pytest
import yaml

from gym4real.bench import stats, suite_score, upper_reference
from gym4real.bench.benchmark import protocol
from gym4real.bench.episodes import score_matrices

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
HEADROOM = (ROOT / "docs" / "headroom.md").read_text(encoding="utf-8")
NUMBER = r"-?[\d,]+(?:\.\d+)?"


def agrees(text: str, value: float) -> bool:
    """Whether ``text`` (``-1,997``, ``1.42``) is ``value`` rounded to the digits it shows."""
    digits = len(text.split(".")[1]) if "." in text else 0
    return abs(float(text.replace(",", "")) - value) <= 0.5 * 10.0**-digits * (1 + 1e-9)


def summary(env: str) -> pd.DataFrame:
    return pd.read_csv(RESULTS / f"{env}-v0-paper" / "summary.csv", index_col="policy")


def section(title: str) -> str:
    """The text of docs/headroom.md's ``### title...`` section."""
    start = HEADROOM.index(f"\n### {title}")
    end = HEADROOM.find("\n### ", start + 1)
    return HEADROOM[start : end if end > 0 else None]


def suite_position(env: str, policy: str) -> float:
    """Where ``policy``'s IQM sits on the suite scale of the section (0 = random, 1 = best rule-based)."""
    env_id = f"gym4real/{env}-v0"
    scores, seeds = score_matrices(pd.read_csv(RESULTS / f"{env}-v0-paper" / "episodes.csv"), env)
    scale = suite_score.scale(env_id, {p: m for p, m in scores.items() if not seeds[p]}, protocol(env_id).rule_based)
    return float(scale.normalise(stats.iqm(scores[policy])))


def test_the_dam_result_and_the_opening_paragraph_repeat_the_dam_sections_numbers() -> None:
    dam = summary("dam")["iqm"]
    text = " ".join(section("dam").split())
    found = re.search(
        rf"`hindsight` ({NUMBER})(?: \(the DP alone: {NUMBER}\))?, PPO \(paper agent\) ({NUMBER}), `max` \(the best rule-based baseline\) ({NUMBER}), "
        rf"`random` ({NUMBER})\. On the suite scale \(0 = `random`, 1 = `max`\) "
        rf"the upper reference sits at ({NUMBER}), the IQM of PPO's test episodes \(all seeds pooled\) at ({NUMBER})",
        text,
    )
    assert found, "docs/headroom.md's dam Result bullet changed its wording: update this test with it"
    upper, ppo, best, random, upper_scale, ppo_scale = found.groups()
    assert agrees(upper, dam["hindsight"]) and agrees(ppo, dam["ppo"])
    assert agrees(best, dam["max"]) and agrees(random, dam["random"])
    assert agrees(upper_scale, suite_position("dam", "hindsight"))
    assert agrees(ppo_scale, suite_position("dam", "ppo"))
    opening = re.search(rf"PPO scoring ({NUMBER}) on dam", HEADROOM)
    assert opening and opening.group(1) == ppo_scale  # the first paragraph says what the dam section says


@pytest.mark.parametrize(("env", "title"), [("microgrid", "microgrid"), ("wds", "wds")])
def test_the_result_tables_of_headroom_md_are_the_sections_iqm_and_mean(env: str, title: str) -> None:
    table = summary(env)
    text = section(title)
    table_text = text[text.index("| policy | IQM") :].split("\n\n", 1)[0]  # the Result table, to its blank line
    rows = re.findall(rf"^\| (.+?) \| \**({NUMBER})\** \| ({NUMBER}) \|$", table_text, re.M)
    assert len(rows) >= 4
    for label, iqm, mean in rows:
        policies = re.findall(r"`(\w+)`", label) or [label.split()[0].lower()]
        for policy in policies:
            assert agrees(iqm, table.loc[policy, "iqm"]), (env, policy, iqm)
            assert agrees(mean, table.loc[policy, "mean"]), (env, policy, mean)


def test_the_microgrid_headroom_and_the_trading_figures_are_the_sections() -> None:
    episodes = pd.read_csv(RESULTS / "microgrid-v0-paper" / "episodes.csv")
    scores, _ = score_matrices(episodes, "microgrid")
    room = upper_reference.headroom(scores["hindsight"], scores["ppo"])
    microgrid = " ".join(section("microgrid").split())
    found = re.search(rf"Headroom over the published PPO: ({NUMBER}) \[({NUMBER}), ({NUMBER})\]", microgrid)
    assert found
    for text, key in zip(found.groups(), ("shortfall", "low", "high"), strict=True):
        assert agrees(text, room[key]), (key, text, room[key])
    trading = summary("trading")
    text = " ".join(section("trading").split())
    found = re.search(
        rf"mean daily objective is ({NUMBER}) USD \(IQM ({NUMBER})\) against Buy&Hold's ({NUMBER}) \(IQM ({NUMBER})\)",
        text,
    )
    assert found
    values = [trading.loc[p, c] for p in ("hindsight", "buy_and_hold") for c in ("mean", "iqm")]
    assert all(agrees(t, v) for t, v in zip(found.groups(), values, strict=True)), (found.groups(), values)


def test_the_planning_times_are_the_sections_own_and_the_elevator_section_repeats_its_row() -> None:
    rows = dict(re.findall(r"^\| `(\w+)-v0` \| [^|]+ \| ([^|]+) \|$", HEADROOM, re.M))
    assert {"dam", "elevator", "microgrid", "trading", "wds"} <= set(rows)
    for env, shown in rows.items():
        report = json.loads((RESULTS / f"{env}-v0-paper" / "report.json").read_text())
        wall = report["upper_references"]["test_wall_time_s"]
        if shown.strip() == "under 1 s":
            assert wall < 1.0
        else:  # the recorded wall time, then (where shown) the CPU time in brackets
            number = re.fullmatch(rf"({NUMBER}) s(?: \(.+\))?", shown.strip())
            assert number and agrees(number.group(1), wall), (env, shown, wall)
    elevator = re.search(r"the 30 test episodes of the protocol took (\d+) s", " ".join(section("elevator").split()))
    assert elevator and f"{elevator.group(1)} s" == rows["elevator"].strip()


def test_the_readme_counts_the_sections_and_the_stand_in_budget_as_the_results_do() -> None:
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    words = {"six": 6, "seven": 7, "eight": 8, "nine": 9, "ten": 10}
    sections = [p for p in RESULTS.iterdir() if (p / "report.json").is_file()]
    said = re.search(r"SHA-256 of `manifest\.json` and `models\.json`\): all (\w+) are", readme)
    assert said and words[said.group(1)] == len(sections)
    runs = pd.read_csv(RESULTS / "trading-v0-paper" / "runs.csv")
    hourly = runs.loc[runs["preset"] == "hourly", "total_timesteps"].unique()
    found = re.search(rf"\(({NUMBER}) steps, ({NUMBER}) % of `paper`'s ({NUMBER})", readme)
    assert found and len(hourly) == 1
    steps, paper = (float(found.group(i).replace(",", "")) for i in (1, 3))
    assert steps == hourly[0] and agrees(found.group(2), 100 * steps / paper)
    presets = ROOT / "packages" / "gym4real-trading" / "src" / "gym4real" / "trading" / "rl"
    for algo in ("dqn", "ppo"):  # the appendix's budget, the `paper` preset's
        assert yaml.safe_load((presets / f"{algo}_paper.yaml").read_text())["total_timesteps"] == paper


def test_the_fingerprint_sentences_name_no_empty_file_count_and_no_dirty_suffix(
    load_script: Callable[[Path], ModuleType],
) -> None:
    verify = load_script(ROOT / "scripts" / "verify_fingerprints.py")
    assert verify.code_words("ba1df74-dirty") == "ba1df74 with uncommitted changes"
    assert verify.code_words("ba1df74") == "ba1df74"
    assert verify.data_words({}, []) == "the env reads no data file, so there is none to compare"
    two = verify.data_words({"a.csv": "1", "b.csv": "2"}, ["b.csv"])
    assert two.startswith("the SHA-256 of the 2 data files read") and two.endswith("copies found here: b.csv")


def test_the_headroom_split_table_is_the_sections_mpc_rows_headrooms_and_own_checks() -> None:
    """docs/headroom.md's *Forecast and learning headroom* table, recomputed from the three sections (issue 46)."""
    from gym4real.bench.numbers import human, human_interval

    start = HEADROOM.index("## Forecast and learning headroom")
    rows = re.findall(r"^\| `(\w+)-v0` \| (.+) \|$", HEADROOM[start : HEADROOM.index("\n## ", start + 1)], re.M)
    assert [env for env, _ in rows] == ["dam", "microgrid", "wds"]
    for env, cells in rows:
        upper, mpc, agent, forecast, learning, check = cells.split(" | ")
        table = summary(env)
        scores, seeds = score_matrices(pd.read_csv(RESULTS / f"{env}-v0-paper" / "episodes.csv"), env)
        (best,) = [p for p in scores if seeds[p]]
        assert upper == f"`hindsight` {human(table.loc['hindsight', 'iqm'])}"
        row = table.loc["mpc"]
        assert mpc == f"{human(row['iqm'])} {human_interval(row['low'], row['high'])}"
        assert agent == f"{best.upper()} {human(table.loc[best, 'iqm'])}"
        split = upper_reference.headroom_split(scores["hindsight"], scores["mpc"], scores[best])
        for text, part in ((forecast, split["forecast"]), (learning, split["learning"])):
            assert text == f"{human(part['shortfall'])} {human_interval(part['low'], part['high'])}", (env, text)
        claims = json.loads((RESULTS / f"{env}-v0-paper" / "claims.json").read_text())
        (own,) = [c for c in claims if not c["paper"] and c["deciding"] == "mpc"]
        assert check == f"{best.upper()} beats MPC: **{own['verdict']}**"
