from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import gym4real
from gym4real.bench import stats, suite_score
from gym4real.bench.upper_reference import PlanCache, check_agent, check_protocol, headroom, headroom_split
from gym4real.cli import main
from gym4real.cli.envs import summary, summary_text
from gym4real.core.errors import ConfigError
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
    record = evaluation.record("mine")["envs"][TRADING]
    assert record["upper_references"]["hindsight"]["bound"] == "exact"
    closed = record["headroom_closed"]["hindsight"]
    random = stats.iqm(result.scores["random"])
    assert closed["share"] == pytest.approx((stats.iqm(mine) - random) / (stats.iqm(upper) - random))
    table = evaluation.table()
    assert "shortfall of mine from hindsight (non-causal upper reference, exact)" in table
    assert f"share of the headroom closed {closed['share']:.3f}" in table
    report = (tmp_path / "out" / "report.md").read_text()
    assert "shortfall from the upper reference" in report and "share of the headroom closed" in report
    assert "Upper reference `hindsight`: **exact**" in report


def test_evaluate_measures_no_headroom_to_an_upper_reference_that_is_not_a_bound() -> None:
    from gym4real.bench.evaluate import EnvResult

    rng = np.random.default_rng(1)
    scores = {
        "random": rng.normal(0, 1, (1, 20)),
        "oracle": rng.normal(1, 1, (1, 20)),
        "mine": rng.normal(2, 1, (2, 20)),
    }
    result = EnvResult(
        "gym4real/robofeeder-planning-v0",
        suite_score.scale("gym4real/robofeeder-planning-v0", {"random": scores["random"]}, ()),
        scores,
        {"random": "baseline", "oracle": "upper", "mine": "agent"},
        {"random": [], "oracle": [], "mine": [0, 1]},
        pd.DataFrame(),
        "none",
    )
    record = result.record("mine")
    assert record["upper_references"]["oracle"]["bound"] == "not a bound"
    assert record["headroom"] == {} and record["headroom_closed"] == {}


def test_headroom_is_the_iqm_difference_with_a_paired_interval() -> None:
    rng = np.random.default_rng(0)
    upper = rng.normal(10, 1, 13)
    agent = upper[None, :] - rng.uniform(0, 2, (3, 13))
    room = headroom(upper, agent)
    assert room["shortfall"] == pytest.approx(stats.iqm(upper) - stats.iqm(agent))
    assert 0 < room["low"] <= room["shortfall"] <= room["high"]
    with pytest.raises(ConfigError, match="same test episodes"):
        headroom(upper, agent[:, :5])


def _iqm(values: np.ndarray) -> float:
    """The interquartile mean of a number of values divisible by 4: the mean of the middle half, sorted."""
    x = np.sort(np.ravel(values))
    return float(x[x.size // 4 : 3 * x.size // 4].mean())


def test_the_headroom_split_at_mpc_adds_up_to_the_headroom_by_brute_force() -> None:
    rng = np.random.default_rng(1)
    upper = rng.normal(10, 1, 12)
    mpc = upper - rng.uniform(0, 3, 12)
    agent = mpc[None, :] - rng.uniform(-1, 3, (3, 12))
    split = headroom_split(upper, mpc, agent)
    assert split["forecast"]["shortfall"] == pytest.approx(_iqm(upper) - _iqm(mpc))
    assert split["learning"]["shortfall"] == pytest.approx(_iqm(mpc) - _iqm(agent))
    total = split["forecast"]["shortfall"] + split["learning"]["shortfall"]
    assert total == pytest.approx(headroom(upper, agent)["shortfall"])
    for part in split.values():
        assert part["low"] <= part["shortfall"] <= part["high"]


def test_the_forecast_headroom_resamples_the_episodes_paired_and_the_learning_headroom_the_seeds_too() -> None:
    """Scores built so that every resample is enumerable: the intervals are the extremes of the enumeration."""
    mpc = np.array([0.0, 100.0, 200.0, 300.0])
    upper = mpc + 10.0  # 10 above mpc in every episode: every paired episode resample gives 10
    split = headroom_split(upper, mpc, np.vstack([mpc - 1.0, mpc - 5.0]))
    assert (split["forecast"]["shortfall"], split["forecast"]["low"], split["forecast"]["high"]) == (10, 10, 10)
    # one score per seed in every episode: the two seeds drawn with replacement give the learning headroom 1 (seed 0
    # twice), 5 (seed 1 twice) or 3 (one each); the episodes drawn change none of them
    flat = np.full(4, 50.0)
    agent = np.vstack([flat - 1.0, flat - 5.0])
    outcomes = {_iqm(flat) - _iqm(agent[[i, j]]) for i in (0, 1) for j in (0, 1)}
    assert outcomes == {1.0, 3.0, 5.0}
    learning = headroom_split(flat + 10.0, flat, agent)["learning"]
    assert learning["shortfall"] == 3.0 and (learning["low"], learning["high"]) == (min(outcomes), max(outcomes))


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


def test_every_upper_reference_declares_its_kind_and_the_oracles_are_not_bounds() -> None:
    from gym4real.bench.upper_reference import bound_references
    from gym4real.core.registry import upper_reference

    kinds = {
        (env_id, name): upper_reference(env_id, name).bound
        for env_id in registry().benchmarks
        for name in non_causal(env_id)
    }
    assert kinds[TRADING, "hindsight"] == kinds["gym4real/elevator-v0", "hindsight"] == "exact"
    assert {kinds[f"gym4real/{d}-v0", "hindsight"] for d in ("dam", "microgrid", "wds")} == {"heuristic"}
    oracles = {k for k in kinds if k[1] == "oracle"}
    assert len(oracles) == 3 and {kinds[k] for k in oracles} == {"not a bound"}
    assert bound_references("gym4real/robofeeder-planning-v0") == [] and bound_references(TRADING) == ["hindsight"]
    with pytest.raises(ConfigError, match="not a non-causal upper reference"):
        upper_reference(TRADING, "buy_and_hold")


def test_the_share_of_the_headroom_closed_runs_from_random_to_the_upper_reference() -> None:
    from gym4real.bench.upper_reference import headroom_closed

    rng = np.random.default_rng(0)
    random = rng.normal(0.0, 1.0, size=(1, 30))
    upper = random + 10.0  # the same episodes, 10 above everywhere
    halfway = random + 5.0 + rng.normal(0.0, 0.1, size=(4, 30))
    assert headroom_closed(upper, random, random, False)["share"] == 0.0
    assert headroom_closed(upper, random, upper, False)["share"] == 1.0
    found = headroom_closed(upper, random, halfway)
    assert found["share"] == pytest.approx(0.5, abs=0.02) and found["low"] <= found["share"] <= found["high"]
    assert found["high"] - found["low"] < 0.05  # the episodes are paired: their spread cancels
    with pytest.raises(ConfigError, match="no headroom"):
        headroom_closed(random, upper, halfway)
    with pytest.raises(ConfigError, match="same test episodes"):
        headroom_closed(upper[:, :10], random, halfway)


def test_figures_name_an_upper_reference_with_its_kind() -> None:
    from gym4real.bench.upper_label import label

    assert label(TRADING, "hindsight") == "hindsight (non-causal upper reference, exact)"
    assert label("gym4real/robofeeder-planning-v0", "oracle") == "oracle (non-causal upper reference, not a bound)"
    assert label("gym4real/wds-v0", "hindsight").startswith("hindsight (non-causal upper reference, heuristic, gap ")
    assert label(TRADING, "buy_and_hold") == "buy_and_hold"
