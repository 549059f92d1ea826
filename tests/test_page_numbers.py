"""Every number the README, docs/headroom.md, the env pages and the main job repeat from the committed results
equals the results' own.

The README and docs/headroom.md are written by hand around the numbers of ``docs/results`` (each section's
``summary.csv``, ``episodes.csv`` and ``report.json``); the env pages (``docs/gen_pages.py``) and the main job's
output (``gym4real bench``) are generated from them. These tests read each repeated number off the page or the
output and recompute it from those files, to the digits shown, so that a page cannot disagree with the results
or with itself (issue 45: "PPO scoring 1.79 on dam" above a dam section saying 1.42).
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
from gym4real.bench.numbers import human
from gym4real.core.registry import upper_reference as reference_spec

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
HEADROOM = (ROOT / "docs" / "headroom.md").read_text(encoding="utf-8")
NUMBER = r"-?[\d,]+(?:\.\d+)?"


def agrees(text: str, value: float) -> bool:
    """Whether ``text`` (``-1,997``, ``1.42``) is ``value`` rounded to the digits it shows."""
    digits = len(text.split(".")[1]) if "." in text else 0
    return abs(float(text.replace(",", "")) - value) <= 0.5 * 10.0**-digits * (1 + 1e-9)


def shows(text: str, value: float) -> bool:
    """Whether ``text`` is ``value`` as a generated page writes it (``human``: four significant digits), or
    rounded to the digits it shows (:func:`agrees`; a difference within float noise shown as 0)."""
    return text == human(value) or agrees(text, value)


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
        rf"`hindsight` ({NUMBER})(?: \(the DP alone: {NUMBER}\))?, PPO \(paper agent\) ({NUMBER}), "
        rf"`max` \(the best rule-based baseline\) ({NUMBER}), "
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
        # measured later (upper_references), or within the section's own test phase (a section run since)
        wall = report.get("upper_references", report)["test_wall_time_s"]
        if shown.strip() == "under 1 s":
            assert wall < 1.0
        else:  # the recorded wall time, then (where shown) the CPU time in brackets
            number = re.fullmatch(rf"({NUMBER}) s(?: \(.+\))?", shown.strip())
            assert number and agrees(number.group(1), wall), (env, shown, wall)
    elevator = re.search(r"the 30 test episodes of the protocol took (\d+) s", " ".join(section("elevator").split()))
    assert elevator and f"{elevator.group(1)} s" == rows["elevator"].strip()


def test_the_oracle_paragraph_counts_the_published_ppo_rows_that_score_more_than_the_oracle() -> None:
    """docs/headroom.md's robofeeder paragraph and table row: where the published PPO beats `oracle` (not a bound)."""
    text = section("robofeeder")
    table = next(line for line in HEADROOM.splitlines() if line.startswith("| `robofeeder-*` | `oracle` |"))
    for env in ("planning", "picking"):
        rows = pd.read_csv(RESULTS / f"robofeeder-{env}-v0-paper" / "episodes.csv")
        oracle = rows[rows["policy"] == "oracle"].set_index("episode")["objective"]
        ppo = rows[rows["policy"] == "ppo"]
        margin = ppo["objective"].to_numpy() - oracle.loc[ppo["episode"]].to_numpy()
        above = ppo[margin > 0]
        found = re.search(
            rf"on {env}-v0 (?:the published PPO scores more than it )?on (\d+) of the (\d+)(?: test episodes)? "
            rf"\((\d+) seed-episode rows?, by (?:up to )?({NUMBER})\)",
            " ".join(text.split()),
        )
        assert found, env
        assert (int(found[1]), int(found[2]), int(found[3])) == (above["episode"].nunique(), len(oracle), len(above))
        assert agrees(found[4], float(margin.max())), env
        episodes, total, most = re.search(
            rf"on (\d+) of {env}-v0's (\d+)(?: test episodes)? \(by (?:up to )?({NUMBER})\)", table
        ).groups()  # type: ignore[union-attr]
        assert (int(episodes), int(total)) == (above["episode"].nunique(), len(oracle)) and agrees(most, margin.max())
        if env == "planning":  # the oracle's registered note, which `evaluate` writes beside its score
            note = reference_spec(f"gym4real/robofeeder-{env}-v0", "oracle").bound_note
            assert f"on {above['episode'].nunique()} of the {len(oracle)} test episodes (by up to {most})" in note


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


SECTIONS = sorted(p.name.removesuffix("-paper") for p in RESULTS.glob("*-paper") if (p / "summary.csv").is_file())
ROW = re.compile(rf"^\| `(\w+)`([^|]*) \| ([^|]+) \| ({NUMBER}) \[({NUMBER}), ({NUMBER})\] \| ({NUMBER}) \|$", re.M)
DIFFERENCE = re.compile(rf"(IQM|spread|success rate) ([\w-]+) - ([\w-]+): ({NUMBER}) \[({NUMBER}), ({NUMBER})\]")


@pytest.fixture(scope="module")
def gen_pages(load_script: Callable[[Path], ModuleType]) -> ModuleType:
    return load_script(ROOT / "docs" / "gen_pages.py")


def env_page(gen_pages: ModuleType, env_id: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    """The env page as `nox -s docs` generates it from the committed results and bench runs (its copies of the
    figures written under ``tmp_path``)."""
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "results").symlink_to(RESULTS)
    monkeypatch.setattr(gen_pages, "DOCS", docs)
    page: str = gen_pages.page(env_id, ROOT / "docs" / "bench")
    return page


def page_section(page: str, title: str) -> str:
    """The text of a page's ``## title`` section, to the next ``## `` heading."""
    start = page.index(f"\n## {title}\n")
    end = page.find("\n## ", start + 1)
    return page[start : end if end > 0 else None]


@pytest.mark.parametrize("env", SECTIONS)
def test_every_number_an_env_page_repeats_from_the_results_is_the_results_own(
    env: str, gen_pages: ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 45: the env pages showed baselines only. Each now shows every policy of its results section, the paper
    agents and the upper reference (labelled with its kind) among them, with the section's IQM, interval and mean;
    its verdicts' differences are the claims' own; its headroom and multi-objective numbers are their files'."""
    from gym4real.bench.mo_reference import summary as mo_summary
    from gym4real.bench.upper_label import label
    from gym4real.core.mo_spec import mo_ids
    from gym4real.core.registry import non_causal, registry

    env_id = f"gym4real/{env}"
    page = env_page(gen_pages, env_id, tmp_path, monkeypatch)
    table = pd.read_csv(RESULTS / f"{env}-paper" / "summary.csv", index_col="policy")
    rows = ROW.findall(page_section(page, "Results of the paper's agents"))
    assert sorted(r[0] for r in rows) == sorted(table.index)  # every policy of the section, once
    upper = non_causal(env_id)
    assert [r[0] for r in rows if r[0] in upper] == [r[0] for r in rows[-len(upper) :]]  # last, not ranked
    for policy, after, kind, iqm, low, high, mean in rows:
        row = table.loc[policy]
        for shown, value in ((iqm, row["iqm"]), (low, row["low"]), (high, row["high"]), (mean, row["mean"])):
            assert shows(shown, value), (env, policy, shown, value)
        if policy in upper:
            assert policy + after == label(env_id, policy) and kind == "upper reference, not ranked"
        else:
            assert after == "" and kind == (f"paper agent ({row['seeds']} seeds)" if row["seeds"] else "baseline")
    assert any(kind.startswith("paper agent") for _, _, kind, *_ in rows)
    claims = [c for c in json.loads((RESULTS / "claims.json").read_text()) if c["env_id"] == env_id]
    shown = [DIFFERENCE.search(line) for line in gen_pages.verdict_table(env_id)[2:]]
    assert len(shown) == len([c for c in claims if c.get("paper", True)])
    for found, claim in zip(shown, [c for c in claims if c.get("paper", True)], strict=True):
        deciding = next(x for x in claim["comparisons"] if x["b"] == claim["deciding"])
        assert found and (found.group(2), found.group(3)) == (deciding["a"], deciding["b"])
        for text, key in zip(found.groups()[3:], ("estimate", "low", "high"), strict=True):
            assert shows(text, deciding[key]), (env, claim["text"], key, text, deciding[key])
    bench = ROOT / "docs" / "bench" / env_id.replace("/", "_") / "summary.csv"
    if "## Headroom" in page and bench.is_file():  # the bench run's means, where it ran an upper reference
        means = pd.read_csv(bench, index_col="policy")["objective_mean"]
        for policy, value in re.findall(rf"^\| `(\w+)` \| ({NUMBER}) \|$", page_section(page, "Headroom"), re.M):
            assert shows(value, means[policy]), (env, policy)
    found_mo = [i for i in mo_ids() if registry().multi_objective[i] == env_id]
    record = mo_summary(found_mo[0]) if found_mo else None
    if record and "reference_point" in record:
        text = page_section(page, "Multi-objective evaluation")
        point = re.search(r"Reference point \(([^)]*)\)", text)
        assert point and all(
            shows(t.strip(), v) for t, v in zip(point.group(1).split(","), record["reference_point"], strict=True)
        )
        fronts = re.findall(rf"^\| `(\w+)` \| \w+ \| ({NUMBER}) \| ({NUMBER}) \|$", text, re.M)
        assert sorted(f[0] for f in fronts) == sorted(record["reference_fronts"])
        for name, hypervolume, eum in fronts:
            front = record["reference_fronts"][name]
            assert shows(hypervolume, front["hypervolume"]) and shows(eum, front["eum"]), (env, name)


@pytest.mark.parametrize("env", SECTIONS)
def test_the_main_jobs_lines_of_the_paper_agents_and_upper_references_are_the_results_own(env: str) -> None:
    from gym4real.bench.reference import published_lines
    from gym4real.bench.upper_label import label
    from gym4real.core.registry import non_causal

    env_id = f"gym4real/{env}"
    table = pd.read_csv(RESULTS / f"{env}-paper" / "summary.csv", index_col="policy")
    lines = published_lines(env_id)
    assert lines[0].startswith("The paper's agents and the non-causal upper reference on this protocol")
    expected = [p for p in table.index if table.loc[p, "kind"] == "agent"]
    expected += [p for p in non_causal(env_id) if p in table.index]
    assert len(lines) == 3 + len(expected)
    for policy, line in zip(expected, lines[3:], strict=True):
        agent = table.loc[policy, "kind"] == "agent"
        name = policy if agent else label(env_id, policy)
        found = re.fullmatch(
            rf"  {re.escape(name)} +(paper agent|upper reference, not ranked) +(\d+|-) +"
            rf"({NUMBER}) \[({NUMBER}), ({NUMBER})\]",
            line,
        )
        assert found, line
        assert found.group(2) == (str(table.loc[policy, "seeds"]) if agent else "-")
        for text, column in zip(found.groups()[2:], ("iqm", "low", "high"), strict=True):
            assert shows(text, table.loc[policy, column]), (env, policy, column, text)


def test_the_main_job_prints_the_paper_agents_and_the_upper_reference_under_its_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The README's main job (`nox -s bench` runs `gym4real bench gym4real/elevator-v0`) on the test protocol."""
    from gym4real.bench.reference import published_lines
    from gym4real.cli import main

    args = ["bench", "gym4real/elevator-v0", "--policies", "longest_first", "--out", str(tmp_path), "--quiet"]
    assert main(args) == 0
    out = capsys.readouterr().out
    lines = published_lines("gym4real/elevator-v0")
    assert "\n".join(lines) in out and out.index("longest_first") < out.index(lines[0])
    assert "hindsight (non-causal upper reference, exact)" in out and "  qlearning " in out and "  sarsa " in out
    assert main([*args[:-1], "--env", "reward_coeff=2", "--quiet"]) == 0  # another protocol: nothing to compare
    assert lines[0] not in capsys.readouterr().out


@pytest.mark.parametrize("env", ["dam-v0", "elevator-v0", "robofeeder-planning-v0"])
def test_reproduces_text_report_names_the_paper_agent_and_the_upper_reference_with_its_kind(env: str) -> None:
    """`gym4real reproduce` prints each section's summary: its numbers as the page writes them, a paper agent and
    the upper reference (with its kind, as the figures label it) named so, each claim's verdict with its mark."""
    from gym4real.bench.upper_label import label
    from gym4real.core.registry import non_causal
    from gym4real.results.reproduce import EnvReport, text_report

    env_id = f"gym4real/{env}"
    table = pd.read_csv(RESULTS / f"{env}-paper" / "summary.csv")
    claims = [c for c in json.loads((RESULTS / "claims.json").read_text()) if c["env_id"] == env_id]
    lines = "\n".join(text_report(env_id, "paper", EnvReport(table, claims))).splitlines()
    assert lines[0] == f"== {env_id} (paper)"
    rows = {line.split()[0]: line for line in lines[2 : 2 + len(table)]}
    assert set(rows) == set(table["policy"])
    for row in table.to_dict("records"):
        line, policy = rows[row["policy"]], row["policy"]
        kind = label(env_id, policy)[len(policy) + 2 : -1] if policy in non_causal(env_id) else None
        expected = kind or ("paper agent" if row["kind"] == "agent" else "baseline")
        assert f" {expected} " in line and f" {human(row['iqm'])} " in line and f" {human(row['low'])} " in line
    assert any(f" {label(env_id, p)[len(p) + 2 : -1]} " in rows[p] for p in non_causal(env_id))
    marks = {"holds": "✅", "refuted": "❌", "inconclusive": "❔"}
    assert [line for line in lines if line.startswith("claim: ")] == [
        f"claim: {c['text']} -> {marks[c['verdict']]} {c['verdict']}" for c in claims
    ]
    assert not any(re.search(r"\de[+-]\d", line) for line in lines)


def test_an_env_whose_module_lies_in_no_package_ships_no_reference_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    """A plugin's env defined in a single module has no ``reference/`` folder: `gym4real bench` shows no paper rows."""
    from gym4real.bench import reference

    monkeypatch.setattr(reference, "domain_package", lambda env_id: "json.decoder")  # a module, not a package
    assert reference.load_reference("gym4real/elevator-v0") is None
    assert reference.published_lines("gym4real/elevator-v0") == []


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


def test_the_trainer_comparisons_of_the_page_recompute_from_the_two_sections_episodes() -> None:
    """Issue 43: each row of the page's *JAX trainer against SB3* table and of ``trainers.json``, recomputed from
    the ``episodes.csv`` of the env's SB3 and JAX sections; an env with both sections has its row, no other."""
    from gym4real.results.trainer_comparison import FILE, compare

    pairs = sorted(p.name for p in RESULTS.glob("*-jax") if (RESULTS / p.name.removesuffix("-jax")).is_dir())
    listed = json.loads((RESULTS / FILE).read_text()) if (RESULTS / FILE).exists() else []
    assert [r["section"] for r in listed] == pairs
    page = (RESULTS / "index.md").read_text(encoding="utf-8")
    assert ("## JAX trainer against SB3" in page) is bool(pairs)
    cell = rf"({NUMBER}) \[({NUMBER}), ({NUMBER})\]"
    for record in listed:
        sb3, jax = (pd.read_csv(RESULTS / name / "episodes.csv") for name in (record["reference"], record["section"]))
        fresh = compare(sb3, jax, record["trainer"])
        assert {k: record[k] for k in fresh} == fresh
        env = record["env_id"].split("/")[1]
        found = re.search(
            rf"^\| `{env}` \| {cell} \| `{fresh['a']}` {cell} \| {cell} \| . \*\*(\w+)\*\* \|", page, re.M
        )
        assert found, (env, "the page has no trainer comparison row of the env")
        keys = [f"b_{k}" for k in ("iqm", "low", "high")] + [f"a_{k}" for k in ("iqm", "low", "high")]
        for text, key in zip(found.groups()[:9], [*keys, "estimate", "low", "high"], strict=True):
            assert shows(text, fresh[key]), (env, key, text, fresh[key])
        assert found.group(10) == fresh["verdict"]
