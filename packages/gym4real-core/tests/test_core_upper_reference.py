from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import gym4real
from gym4real.bench import stats, suite_score
from gym4real.bench.upper_reference import PlanCache, check_agent, check_protocol, headroom
from gym4real.cli import main
from gym4real.core.errors import ConfigError
from gym4real.core.info import summary, summary_text
from gym4real.core.registry import list_envs, non_causal, registry

TRADING = "gym4real/trading-v0"


def test_the_upper_references_of_the_domains() -> None:
    assert non_causal(TRADING) == ["hindsight"]
    assert non_causal("gym4real/dam-v0") == ["hindsight"]
    assert non_causal("gym4real/dam-mo-v0") == ["hindsight"]  # a vector-reward variant: its env's
    assert non_causal("gym4real/robofeeder-picking-v0") == ["oracle"]  # the ground-truth oracle plays the role
    assert "random" not in non_causal(TRADING)


def test_no_protocol_makes_an_upper_reference_an_anchor_or_a_claim_member() -> None:
    for env_id in registry().benchmarks:
        check_protocol(env_id)


def test_a_protocol_naming_an_upper_reference_as_rule_based_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    import dataclasses

    spec = registry().benchmarks[TRADING]
    bad = dataclasses.replace(spec, policies=(*spec.policies, "hindsight"), rule_based=("flat", "hindsight"))
    monkeypatch.setitem(registry().benchmarks, TRADING, bad)
    with pytest.raises(ConfigError, match=r"rule_based.*hindsight"):
        check_protocol(TRADING)


def test_the_suite_scale_never_anchors_on_an_upper_reference() -> None:
    anchors = {"random": -5.0, "flat": 0.0, "hindsight": 900.0}
    scale = suite_score.scale(TRADING, anchors, ("flat", "hindsight"))
    assert scale.best == "flat" and scale.top == 0.0
    assert scale.normalise(900.0) == pytest.approx(181.0)  # where hindsight sits on the scale


def test_info_marks_the_upper_reference_in_text_and_json(capsys: pytest.CaptureFixture[str]) -> None:
    record = summary(TRADING)
    assert list(record["non_causal"]) == ["hindsight"] and "hindsight" in record["baselines"]
    text = summary_text(record)
    assert "hindsight (non-causal upper reference" in text
    assert main(["info", TRADING, "--json"]) in (0, None)
    printed = json.loads(capsys.readouterr().out)
    assert printed["non_causal"] == ["hindsight"]


def test_evaluate_refuses_an_upper_reference_as_the_agent_without_the_flag(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="non-causal upper reference"):
        gym4real.evaluate({"mine": "hindsight"}, [TRADING], references=tmp_path)
    assert main(["evaluate", "hindsight", "--envs", TRADING, "--out", str(tmp_path / "o")]) == 2
    check_agent(TRADING, "mine", "hindsight", allow=True)  # the explicit flag
    check_agent(TRADING, "mine", "flat", allow=False)  # a causal baseline is fine


def test_evaluate_reports_the_agents_shortfall_from_hindsight(tmp_path: Path) -> None:
    evaluation = gym4real.evaluate({"mine": "flat"}, [TRADING], references=tmp_path, out=tmp_path / "out")
    result = evaluation.envs[TRADING]
    assert result.kinds["hindsight"] == "upper"
    upper, mine = result.scores["hindsight"], result.scores["mine"]
    room = evaluation.record("mine")["envs"][TRADING]["headroom"]["hindsight"]
    assert room["shortfall"] == pytest.approx(stats.iqm(upper) - stats.iqm(mine))
    assert room["low"] <= room["shortfall"] <= room["high"]
    assert room["shortfall"] > 0  # the exact optimum beats staying flat on the test days
    assert result.scale.best != "hindsight"
    assert "shortfall of mine from hindsight" in evaluation.table()
    assert "shortfall from the upper reference" in (tmp_path / "out" / "report.md").read_text()


def test_headroom_is_the_iqm_difference_with_a_paired_interval() -> None:
    rng = np.random.default_rng(0)
    upper = rng.normal(10, 1, 13)
    agent = upper[None, :] - rng.uniform(0, 2, (3, 13))
    room = headroom(upper, agent)
    assert room["shortfall"] == pytest.approx(stats.iqm(upper) - stats.iqm(agent))
    assert 0 < room["low"] <= room["shortfall"] <= room["high"]
    with pytest.raises(ConfigError, match="same test episodes"):
        headroom(upper, agent[:, :5])


def test_plan_cache_round_trip_and_a_damaged_file_is_ignored(tmp_path: Path) -> None:
    path = tmp_path / "plans.json"
    cache = PlanCache(path)
    assert cache.get("k") is None
    cache.put("k", {"decisions": [1.0, 2.0]})
    assert PlanCache(path).get("k") == {"decisions": [1.0, 2.0]}
    path.write_text("{not json")
    assert PlanCache(path).get("k") is None
    assert PlanCache(None).get("k") is None


def test_every_env_with_an_upper_reference_lists_it_among_its_baselines() -> None:
    for env_id in list_envs():
        assert set(non_causal(env_id)) <= set(gym4real.env_info(env_id).baselines)


def test_evaluate_without_headroom_runs_no_upper_reference(tmp_path: Path) -> None:
    evaluation = gym4real.evaluate({"mine": "flat"}, [TRADING], references=tmp_path, headroom=False)
    assert "hindsight" not in evaluation.envs[TRADING].scores
    assert evaluation.record("mine")["envs"][TRADING]["headroom"] == {}
