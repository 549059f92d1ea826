"""Multi-objective evaluation: metrics known by hand, the shipped reference points and fronts, evaluate --mo."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from gym4real.bench import mo_metrics, mo_reference
from gym4real.bench.mo_eval import agents_of, policies_of
from gym4real.core.errors import ConfigError, ReferenceMismatchError
from gym4real.core.mo_spec import mo_ids, mo_spec

MO_IDS = ["gym4real/dam-mo-v0", "gym4real/microgrid-mo-v0", "gym4real/wds-mo-v0"]


# -- metrics on examples computed by hand -------------------------------------------------------------------


def test_hypervolume_of_a_staircase_is_the_sum_of_its_rectangles() -> None:
    # (1, 3), (2, 2), (3, 1) above the origin: columns of widths 1, 1, 1 and heights 3, 2, 1
    assert mo_metrics.hypervolume(np.array([[1.0, 3.0], [2.0, 2.0], [3.0, 1.0]])) == pytest.approx(6.0)
    # a dominated point and one below the reference point add nothing
    extra = np.array([[1.0, 3.0], [2.0, 2.0], [3.0, 1.0], [1.0, 1.0], [5.0, -0.5]])
    assert mo_metrics.hypervolume(extra) == pytest.approx(6.0)
    # reference point (1.5, 0.5): (1, 3) no longer dominates it; (2, 2) and (3, 1) leave 0.5 x 1.5 + 1 x 0.5
    assert mo_metrics.hypervolume(extra[:3], np.array([1.5, 0.5])) == pytest.approx(1.25)
    assert mo_metrics.hypervolume(np.array([[-1.0, 2.0]])) == 0.0


def test_hypervolume_of_boxes_in_three_objectives_is_their_union() -> None:
    assert mo_metrics.hypervolume(np.array([[2.0, 3.0, 4.0]])) == pytest.approx(24.0)
    # two unit-height boxes 2 x 1 and 1 x 2 overlapping in a unit cube: 2 + 2 - 1
    assert mo_metrics.hypervolume(np.array([[2.0, 1.0, 1.0], [1.0, 2.0, 1.0]])) == pytest.approx(3.0)


def test_hypervolume_refuses_non_finite_values() -> None:
    with pytest.raises(ValueError, match="non-finite"):
        mo_metrics.hypervolume(np.array([[1.0, np.nan]]))


def test_expected_utility_is_the_mean_best_linear_utility() -> None:
    weights = np.array([[1.0, 0.0], [0.5, 0.5], [0.0, 1.0]])
    # corners (1, 0) and (0, 1): utilities max(1, 0), max(.5, .5), max(0, 1)
    assert mo_metrics.expected_utility(np.array([[1.0, 0.0], [0.0, 1.0]]), weights) == pytest.approx(2.5 / 3)
    # adding the middle point (0.6, 0.6) raises the middle weight's utility to 0.6
    three = np.array([[1.0, 0.0], [0.0, 1.0], [0.6, 0.6]])
    assert mo_metrics.expected_utility(three, weights) == pytest.approx(2.6 / 3)


@pytest.mark.parametrize(("objectives", "count", "divisions"), [(2, 50, 49), (3, 55, 9), (4, 56, 5)])
def test_simplex_weights_are_the_smallest_das_dennis_lattice_of_50(objectives: int, count: int, divisions: int) -> None:
    weights = mo_metrics.simplex_weights(objectives)
    assert weights.shape == (count, objectives)
    assert math.comb(divisions + objectives - 1, objectives - 1) == count
    np.testing.assert_allclose(weights.sum(axis=1), 1.0)
    assert (weights >= 0).all()
    np.testing.assert_allclose(weights * divisions, np.round(weights * divisions), atol=1e-9)
    assert len({tuple(np.round(w * divisions).astype(int)) for w in weights}) == count  # all distinct


def test_nondominated_keeps_the_front_and_duplicates() -> None:
    points = np.array([[1.0, 2.0], [2.0, 1.0], [0.5, 0.5], [1.0, 2.0]])
    assert mo_metrics.nondominated(points).tolist() == [True, True, False, True]


# -- the declared objectives and the shipped references -------------------------------------------------------


def test_every_vector_reward_id_declares_its_evaluation() -> None:
    assert mo_ids() == MO_IDS


def test_reward_weights_give_each_component_its_objectives_weight() -> None:
    spec = mo_spec("gym4real/dam-mo-v0")
    components = ("deficit", "overflow", "starving", "wasted_water", "clipping")
    np.testing.assert_array_equal(spec.reward_weights([0.3, 0.7], components), [0.3, 0.7, 0.3, 0.0, 0.0])
    with pytest.raises(ConfigError, match="2 objectives"):
        spec.reward_weights([1.0], components)


@pytest.mark.parametrize("env_id", MO_IDS)
def test_objectives_sum_to_the_papers_objective(env_id: str) -> None:
    from gym4real.bench.benchmark import protocol

    used = sorted(c for o in mo_spec(env_id).objectives for c in o.components)
    assert used == sorted(protocol(env_id).objective)


@pytest.mark.parametrize("env_id", MO_IDS)
def test_shipped_reference_point_is_the_rule_on_randoms_reference_runs(env_id: str) -> None:
    reference = mo_reference.load(env_id)  # refuses another protocol (fingerprint)
    assert reference is not None
    # random's test episodes are the ones the env's reference runs hold (same protocol, fingerprinted)
    runs = mo_reference.reference_run_objectives(env_id, "random")
    np.testing.assert_array_equal(reference.random_episodes, runs)
    worst, best = runs.min(axis=0), runs.max(axis=0)
    np.testing.assert_allclose(reference.scale.reference_point, worst - 0.1 * (best - worst), rtol=1e-15)
    np.testing.assert_array_equal(reference.scale.top, best)
    assert (reference.scale.reference_point < worst).all()


def test_random_run_now_reproduces_the_shipped_episodes_on_a_short_protocol() -> None:
    # the full protocol runs for about a minute per id; its first two test years (dam) take a few seconds
    env_id = "gym4real/dam-mo-v0"
    reference = mo_reference.load(env_id)
    assert reference is not None
    plan, kwargs = mo_reference.test_plan(env_id)
    from gym4real.bench.policies import make_policy

    now = mo_reference.run_objectives(env_id, lambda env: make_policy(env_id, "random", env), plan[:2], kwargs, "r")
    np.testing.assert_array_equal(now, reference.random_episodes[:2])


@pytest.mark.parametrize("env_id", MO_IDS)
def test_shipped_fronts_values_follow_from_their_episodes(env_id: str) -> None:
    reference = mo_reference.load(env_id)
    assert reference is not None
    spec = mo_spec(env_id)
    assert set(reference.fronts) == {*(s.name for s in spec.sweeps), mo_reference.RULE_BASED, "hindsight"}
    for name, front in reference.fronts.items():
        shipped = reference.record["fronts"][name]
        points = reference.scale.normalise(front.means)
        assert shipped["hypervolume"] == pytest.approx(mo_metrics.hypervolume(points), rel=1e-12)
        assert shipped["eum"] == pytest.approx(mo_metrics.expected_utility(points, reference.weights), rel=1e-12)
        assert shipped["hypervolume"] > 0
        flags = [p["nondominated"] for p in shipped["policies"]]
        assert flags == mo_metrics.nondominated(front.means).tolist()
    # the union front is at least as good as each sweep's
    union = reference.record["fronts"][mo_reference.RULE_BASED]["hypervolume"]
    assert all(union >= reference.record["fronts"][s.name]["hypervolume"] - 1e-12 for s in spec.sweeps)


#: A sweep's point at a registered baseline's parameter -> that baseline (the same policy).
BASELINE_POINTS = {
    "gym4real/dam-mo-v0": {
        "constant_release:fraction=0.5": "mean",
        "constant_release:fraction=1": "max",
        "scaled_ead:scale=1": "ead",
    },
    "gym4real/microgrid-mo-v0": {
        "constant_fraction:fraction=0": "only_market",
        "constant_fraction:fraction=0.5": "fifty_fifty",
        "constant_fraction:fraction=1": "battery_first",
    },
    "gym4real/wds-mo-v0": {
        "constant_pumps:action=1": "p79",
        "constant_pumps:action=2": "p78",
        "tank_level_rule:low=5,high=8": "default",
    },
}


@pytest.mark.parametrize("env_id", MO_IDS)
def test_sweep_points_at_a_baselines_parameter_equal_its_reference_runs(env_id: str) -> None:
    # measured independently: the sweeps by scripts/export_mo_references.py (microgrid: the batched env),
    # the baselines by `gym4real reproduce` with the single env
    front = mo_reference.load(env_id).fronts[mo_reference.RULE_BASED]  # type: ignore[union-attr]
    for label, baseline in BASELINE_POINTS[env_id].items():
        runs = mo_reference.reference_run_objectives(env_id, baseline)
        # equal to the last bits (EPANET's sums of the wds may differ by an ulp between two processes)
        np.testing.assert_allclose(front.episodes[front.labels.index(label)], runs, rtol=1e-13, err_msg=label)


def test_a_reference_measured_on_another_protocol_is_refused(tmp_path: Path) -> None:
    env_id = "gym4real/dam-mo-v0"
    shutil.copy(mo_reference.path_of(env_id), tmp_path)
    path = mo_reference.path_of(env_id, tmp_path)
    record = json.loads(path.read_text())
    record["fingerprint"]["episodes_sha256"] = "0" * 64
    record["objectives"][0]["components"] = ["deficit"]
    path.write_text(json.dumps(record))
    with pytest.raises(ReferenceMismatchError, match=r"episodes_sha256.*objectives.*export_mo_references"):
        mo_reference.load(env_id, tmp_path)


def test_add_front_adds_a_weighted_front_and_keeps_the_rest(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    env_id = "gym4real/dam-mo-v0"
    shutil.copy(mo_reference.path_of(env_id), tmp_path)
    before = mo_reference.load(env_id, tmp_path)
    assert before is not None
    scale, episodes = before.scale, before.random_episodes.shape[0]

    def planner(env: Any, weights: np.ndarray, seed: int) -> np.ndarray:
        assert seed == 3
        return weights

    def fake_run(env_id: str, build: Any, plan: Any, kwargs: Any, label: str) -> np.ndarray:
        # a planner whose every test episode scores its weights on the normalised scale, with no simulation
        weights = build(None)
        return np.tile(scale.reference_point + weights * (scale.top - scale.reference_point), (episodes, 1))

    monkeypatch.setattr(mo_reference, "run_objectives", fake_run)
    mo_reference.add_front(
        env_id, "planner", "hindsight", "a planner scoring its weights", planner, seed=3, folder=tmp_path
    )
    after = mo_reference.load(env_id, tmp_path)
    assert after is not None
    entry = after.record["fronts"]["planner"]
    assert len(entry["policies"]) == 50 and entry["kind"] == "hindsight"
    # points (k/49, 1 - k/49): a staircase of 49 columns of width 1/49 and heights 1 - k/49, k = 1..49
    assert entry["hypervolume"] == pytest.approx(sum((1 - k / 49) / 49 for k in range(1, 50)), rel=1e-9)
    assert entry["hypervolume"] == pytest.approx(24 / 49, rel=1e-9)
    # every weight's best point is a corner of the lattice: utility max(w1, w2)
    assert entry["eum"] == pytest.approx(np.mean([max(k / 49, 1 - k / 49) for k in range(50)]), rel=1e-9)
    np.testing.assert_array_equal(after.scale.reference_point, before.scale.reference_point)
    for name in before.fronts:
        assert after.record["fronts"][name] == before.record["fronts"][name]
    with pytest.raises(ConfigError, match="already has a front `planner`"):
        mo_reference.add_front(env_id, "planner", "hindsight", "again", planner, folder=tmp_path)


@pytest.mark.parametrize("env_id", MO_IDS)
def test_the_shipped_hindsight_front_is_an_upper_reference_of_the_rule_based_front(env_id: str) -> None:
    """The hindsight planners' weighted front (scripts/export_mo_references.py --hindsight --divisions 7), from the
    shipped file: its hypervolume and EUM are at least the rule-based front's; it ran at the 8 weights k / 7 of the
    EUM lattice, handed the raw weights that rank as each does on the normalised scale, and its CPU time is kept."""
    reference = mo_reference.load(env_id)
    assert reference is not None
    hindsight, rules = reference.fronts["hindsight"], reference.fronts[mo_reference.RULE_BASED]
    assert hindsight.kind == "hindsight" and "non-causal" in hindsight.description
    assert hindsight.labels == ["w=" + ",".join(f"{x:.4g}" for x in w) for w in mo_metrics.simplex_weights(2, 8)]
    assert "lattice of 7 divisions" in hindsight.description
    assert reference.record["manifest"]["cpu_s (hindsight)"] > 0

    def values(front: mo_reference.Front) -> tuple[float, float]:
        points = reference.scale.normalise(front.means)
        return mo_metrics.hypervolume(points), mo_metrics.expected_utility(points, reference.weights)

    (hv, eum), (rule_hv, rule_eum) = values(hindsight), values(rules)
    assert hv >= rule_hv and eum >= rule_eum
    # stronger: each rule-based policy's mean vector is weakly dominated by one of the hindsight front's (to the
    # last digits: wds's `both pumps on` serves the demand the hindsight planner of the DSR alone serves)
    for label, point in zip(rules.labels, rules.means, strict=True):
        slack = (hindsight.means - point + 1e-9 * np.abs(point)).min(axis=1).max()
        assert slack >= 0, label


def test_raw_weights_rank_as_the_weights_on_the_normalised_scale() -> None:
    scale = mo_reference.Scale(np.array([-10.0, -300.0]), np.array([0.0, -100.0]))
    raw = scale.raw_weights([0.5, 0.5])
    np.testing.assert_allclose(raw, [20 / 21, 1 / 21])  # 0.5 / 10 and 0.5 / 200, summing to 1
    rng = np.random.default_rng(0)
    a, b = rng.uniform(-300, 0, (2, 100, 2))
    w = np.array([0.3, 0.7])
    better = (scale.normalise(a) @ w) > (scale.normalise(b) @ w)
    np.testing.assert_array_equal(better, (a @ scale.raw_weights(w)) > (b @ scale.raw_weights(w)))
    for bad in ([1.0], [-1.0, 2.0], [0.0, 0.0], [np.nan, 1.0]):
        with pytest.raises(ConfigError, match="non-negative"):
            scale.raw_weights(bad)


def test_component_weights_weigh_each_step_as_its_objective() -> None:
    spec = mo_spec("gym4real/dam-mo-v0")
    assert spec.component_weights([0.25, 0.75]) == {"deficit": 0.25, "starving": 0.25, "overflow": 0.75}
    with pytest.raises(ConfigError, match="shortage"):
        spec.component_weights([0.0, 0.0])


def test_add_front_at_given_normalised_weights_replaces_a_front(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    env_id = "gym4real/dam-mo-v0"
    shutil.copy(mo_reference.path_of(env_id), tmp_path)
    reference = mo_reference.load(env_id, tmp_path)
    assert reference is not None
    given: list[np.ndarray] = []

    def planner(env: Any, weights: np.ndarray) -> np.ndarray:
        given.append(weights)
        return weights

    def fake_run(env_id: str, build: Any, plan: Any, kwargs: Any, label: str) -> np.ndarray:
        return np.tile(build(None), (len(plan), 1))

    monkeypatch.setattr(mo_reference, "run_objectives", fake_run)
    grid = np.array([[1.0, 0.0], [0.5, 0.5], [0.0, 1.0]])
    for _ in range(2):  # the second run replaces the first
        mo_reference.add_front(
            env_id, "mine", "hindsight", "three weights", planner, folder=tmp_path, weights=grid, normalised=True,
            replace=True,
        )  # fmt: skip
    after = mo_reference.load(env_id, tmp_path)
    assert after is not None
    assert after.fronts["mine"].labels == ["w=1,0", "w=0.5,0.5", "w=0,1"]
    np.testing.assert_allclose(given[:3], [reference.scale.raw_weights(w) for w in grid])
    assert "cpu_s (mine)" in after.record["manifest"]
    with pytest.raises(ConfigError, match="summing to 1"):
        mo_reference.add_front(env_id, "other", "x", "y", planner, folder=tmp_path, weights=np.array([[1.0, 1.0]]))


def test_the_reference_point_rule_needs_a_range() -> None:
    with pytest.raises(ConfigError, match="same on every test episode"):
        mo_reference.reference_scale(np.array([[1.0, 0.0], [2.0, 0.0]]), 0.1)


# -- the sweeps' factories are the registered baselines at their parameter --------------------------------------


def test_sweep_factories_contain_the_registered_baselines() -> None:
    from gym4real.dam import baselines as dam

    env = gym.make("gym4real/dam-v0")
    try:
        np.testing.assert_array_equal(dam.constant_release(env, 0.5)(None), dam.mean(env)(None))
        np.testing.assert_array_equal(dam.constant_release(env, 1.0)(None), dam.max_release(env)(None))
        env.reset(seed=0)
        for _ in range(5):
            env.step(env.action_space.sample())
        ead, scaled = dam.ead(env)(None), dam.scaled_ead(env, 2.0)(None)
        assert ead[0] > 0
        np.testing.assert_array_equal(dam.scaled_ead(env, 1.0)(None), ead)
        np.testing.assert_array_equal(scaled, 2.0 * ead)
    finally:
        env.close()
    from gym4real.microgrid import baselines as mg

    np.testing.assert_array_equal(mg.constant_fraction(None, 0.0)(None), mg.only_market(None)(None))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="fraction"):
        mg.constant_fraction(None, 1.5)  # type: ignore[arg-type]


def test_tank_level_rule_at_the_default_levels_is_the_default_baseline() -> None:
    from gym4real.wds import baselines as wds

    env = gym.make("gym4real/wds-v0", preset="test")
    try:
        assert wds.tank_level_rule(env, 5.0, 8.0)._pairs == wds.default(env)._pairs
        moved = wds.tank_level_rule(env, 2.0, 5.0)
        assert [(low, high) for _, _, low, high in moved._pairs] == [(2.0, 5.0)] * len(moved._pairs)
        assert wds.constant_pumps(env, 2)(None) == wds.p78(env)(None)
    finally:
        env.close()


# -- evaluate --mo ------------------------------------------------------------------------------------------------


def test_info_json_shows_the_objectives_and_the_reference_point(capsys: pytest.CaptureFixture[str]) -> None:
    from gym4real.cli import main

    main(["info", "gym4real/wds-mo-v0", "--json"])
    record = json.loads(capsys.readouterr().out)["multi_objective"]
    assert [o["name"] for o in record["objectives"]] == ["dsr", "overflow"]
    shipped = mo_reference.load("gym4real/wds-mo-v0")
    assert shipped is not None
    assert record["reference_point"] == shipped.scale.reference_point.tolist()
    assert set(record["reference_fronts"]) == {"constant_pumps", "tank_level_rule", "rule_based", "hindsight"}


def test_cli_arguments_group_into_sets_by_name() -> None:
    found = agents_of(["a=mean", "a=max", "b=pkg.mod:factory", "ead"])
    assert found == {"a": ["mean", "max"], "b": "pkg.mod:factory", "agent": "ead"}


def test_a_weight_conditioned_factory_is_asked_for_each_eum_weight_and_seed() -> None:
    calls: list[tuple[tuple[float, ...], int]] = []

    def factory(env: Any, weights: np.ndarray, seed: int) -> Any:
        calls.append((tuple(weights), seed))
        return lambda obs: env.action_space.sample()

    built = policies_of("gym4real/wds-mo-v0", "agent", factory, seed=7)
    assert len(built) == 50
    env = gym.make("gym4real/wds-mo-v0", preset="test")
    try:
        for _, build in built:
            build(env)
    finally:
        env.close()
    np.testing.assert_allclose([w for w, _ in calls], mo_metrics.simplex_weights(2))
    assert {s for _, s in calls} == {7}


def test_an_agents_hypervolume_is_the_mean_over_its_seeds_with_a_seed_and_episode_interval() -> None:
    from gym4real.bench.mo_eval import AgentRun, _agent_record

    spec = mo_spec("gym4real/wds-mo-v0")
    scale = mo_reference.Scale(np.zeros(2), np.ones(2))  # raw values are normalised ones
    # seed 0: one policy at (1, 1) on both episodes (volume 1); seed 1: (0.5, 0.5) (volume 0.25)
    values = np.array([[[[1.0, 1.0], [1.0, 1.0]]], [[[0.5, 0.5], [0.5, 0.5]]]])
    run = AgentRun("agent", ["p"], [0, 1], True, values)
    front = mo_reference.Front(
        "hand", "rule_based", "(2, 1) and (1, 2)", ["a", "b"], np.array([[[2.0, 1.0]] * 2, [[1.0, 2.0]] * 2])
    )
    reference = mo_reference.MOReference("gym4real/wds-mo-v0", spec, scale, np.zeros((2, 2)), {"hand": front}, {})
    record = _agent_record(run, reference)
    hv = record["hypervolume"]
    assert hv["value"] == pytest.approx((1.0 + 0.25) / 2)
    # resampling the seeds gives both, one or the other: 0.25, 0.625 or 1, so the interval spans them
    assert hv["low"] == pytest.approx(0.25) and hv["high"] == pytest.approx(1.0)
    # the front's volume is 2 + 2 - 1 = 3, on every replicate (its episodes are identical)
    assert record["gap"]["hand"]["hypervolume"]["value"] == pytest.approx(3.0 - 0.625)
    weights = mo_metrics.simplex_weights(2)
    assert record["eum"]["value"] == pytest.approx((1.0 + 0.5) / 2)  # w . (c, c) = c for every weight
    assert record["gap"]["hand"]["eum"]["value"] == pytest.approx(
        np.mean(np.maximum(weights @ [2.0, 1.0], weights @ [1.0, 2.0])) - 0.75
    )


@pytest.mark.slow
def test_evaluate_mo_of_a_rule_based_sweep_reproduces_the_shipped_front(tmp_path: Path) -> None:
    from gym4real.cli import main

    env_id = "gym4real/dam-mo-v0"
    code = main(
        [
            "evaluate",
            "--mo",
            "--envs",
            env_id,
            "--out",
            str(tmp_path),
            "rules=gym4real.dam.multi_objective:SCALED_EAD.policies",
        ]
    )
    assert code in (0, None)
    score = json.loads((tmp_path / "score.json").read_text())["mo"][env_id]
    shipped = mo_reference.load(env_id).record["fronts"]["scaled_ead"]  # type: ignore[union-attr]
    agent = score["agents"]["rules"]
    assert agent["hypervolume"]["value"] == pytest.approx(shipped["hypervolume"], rel=1e-12)
    assert agent["eum"]["value"] == pytest.approx(shipped["eum"], rel=1e-12)
    assert agent["gap"]["scaled_ead"]["hypervolume"]["value"] == pytest.approx(0.0, abs=1e-12)
    assert agent["hypervolume"]["low"] <= agent["hypervolume"]["value"] <= agent["hypervolume"]["high"]
    assert agent["hypervolume"]["low"] < agent["hypervolume"]["high"]  # episodes resampled
    assert [p["label"] for p in agent["front"]] == [p["label"] for p in shipped["policies"]]
    assert (tmp_path / "pareto-dam-mo-v0.png").is_file()
    assert (tmp_path / "mo_episodes.csv").read_text().count("\n") == 1 + 6 * 13


def test_the_pareto_plot_draws_the_hindsight_front_as_a_non_causal_upper_reference(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import matplotlib.figure

    from gym4real.bench.mo_eval import MOResult, pareto_plot

    drawn: list[matplotlib.figure.Figure] = []
    save = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(
        matplotlib.figure.Figure, "savefig", lambda fig, path, **kw: drawn.append(fig) or save(fig, path, **kw)
    )
    shipped = mo_reference.load("gym4real/dam-mo-v0")
    assert shipped is not None and "hindsight" in shipped.fronts
    pareto_plot(MOResult("gym4real/dam-mo-v0", shipped, {}), tmp_path / "pareto.png")
    ax = drawn[0].axes[0]
    entries = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "hindsight (non-causal upper reference)" in entries and "hindsight (hindsight)" not in entries
    assert "rule_based" in entries  # a front named for its kind is not labelled twice
    stars = [line for line in ax.lines if line.get_marker() == "*"]
    assert len(stars) == 1 and len(stars[0].get_xdata()) == len(shipped.fronts["hindsight"].labels)
    assert all(line.get_color() == "black" for line in stars)


def test_the_env_page_documents_the_objectives_reference_point_and_fronts(load_script: Any) -> None:
    gen_pages = load_script(Path(__file__).resolve().parents[1] / "docs" / "gen_pages.py")
    text = "\n".join(gen_pages.mo_section("gym4real/dam-v0"))
    assert "## Multi-objective evaluation" in text
    assert "| `shortage` | `deficit` + `starving` |" in text and "| `flooding` | `overflow` |" in text
    assert "Left out:" in text and "wasted_water" in text
    shipped = mo_reference.load("gym4real/dam-mo-v0")
    assert shipped is not None
    assert ", ".join(f"{v:.6g}" for v in shipped.scale.reference_point) in text
    for name, front in shipped.record["fronts"].items():
        assert f"| `{name}` | {front['kind']} | {front['hypervolume']:.4f} | {front['eum']:.4f} |" in text
    assert "`hindsight` (hindsight): non-causal upper reference" in text
    assert gen_pages.mo_section("gym4real/elevator-v0") == []
