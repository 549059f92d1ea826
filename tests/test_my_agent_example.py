"""examples/my_agent.py: the two factories docs/evaluate.md shows, run through `gym4real evaluate` as it says."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd
import pytest

import gym4real
from gym4real.bench import mo_eval
from gym4real.cli import main

ROOT = Path(__file__).resolve().parents[1]


def documented(command: str) -> list[str]:
    """The arguments after `gym4real evaluate` of the line of docs/evaluate.md that names ``command``."""
    text = (ROOT / "docs" / "evaluate.md").read_text(encoding="utf-8")
    line = next(line for line in text.splitlines() if line.startswith("gym4real evaluate") and command in line)
    return [a.strip('"') for a in line.split()[2:]]


def test_the_plain_factory_is_scored_per_seed_as_the_page_shows(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(ROOT)  # the command line imports `examples.my_agent` from the working folder
    args = documented("examples.my_agent:make_policy")
    assert args[:4] == ["mine=examples.my_agent:make_policy", "--envs", "gym4real/trading-v0", "--seeds"]
    assert main(["evaluate", *args, "--out", str(tmp_path)]) in (0, None)
    assert re.search(r"^\s+mine\s+agent\s+2\s", capsys.readouterr().out, re.M)
    episodes = pd.read_csv(tmp_path / "agent_episodes.csv")
    assert sorted(episodes["seed"].unique()) == [0, 1] and len(episodes) == 2 * 68  # 68 test days per seed
    score = json.loads((tmp_path / "score.json").read_text())
    assert "mine" in json.dumps(score)


@pytest.mark.slow
def test_the_weight_conditioned_factory_is_run_at_every_eum_weight(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(ROOT)
    args = documented("examples.my_agent:make_weighted_policy")
    assert args[:2] == ["--mo", "release=examples.my_agent:make_weighted_policy"]
    assert main(["evaluate", *args, "--out", str(tmp_path)]) in (0, None)
    out = capsys.readouterr().out
    agent = json.loads((tmp_path / "score.json").read_text())["mo"]["gym4real/dam-mo-v0"]["agents"]["release"]
    assert agent["policies"] == 50 and agent["seeds"] == 1  # the 50 EUM weights of two objectives
    front = [p["mean"] for p in agent["front"]]
    assert len({tuple(m) for m in front}) > 1  # the weights change the release, so the points differ
    table = out[out.index("== gym4real/dam-mo-v0") : out.index("score.json (its")].splitlines()[1:]  # the table
    assert "release: 50 policies, 1 seed(s)" in out
    assert all(len(line) <= mo_eval.TABLE_WIDTH for line in table), max(table, key=len)  # no line cut on a page


def test_evaluate_mo_is_a_top_level_api_the_tutorial_uses() -> None:
    assert gym4real.evaluate_mo is mo_eval.evaluate_mo and "evaluate_mo" in gym4real.__all__
    tutorial = (ROOT / "examples" / "tutorials" / "tutorial_7_multi_objective_evaluation.py").read_text()
    assert "gym4real.evaluate_mo(" in tutorial and "gym4real.bench.mo_eval" not in tutorial
