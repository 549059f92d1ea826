"""``gym4real evaluate``: your agent on the test protocols beside reference runs, and the suite score (issue 24).

The reference runs here are built from a real run of elevator's baselines plus a synthetic two-seed agent,
written in the layout ``gym4real reproduce`` gives the results page and exported as a domain would ship them.
"""

from __future__ import annotations

import json
import textwrap
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

import gym4real
from gym4real.bench.episodes import score_matrices
from gym4real.bench.reference import load_reference
from gym4real.cli import main
from gym4real.core.errors import ConfigError, PolicyError, ReferenceMismatchError

ENV = "gym4real/elevator-v0"


@pytest.fixture(scope="module")
def references(tmp_path_factory: pytest.TempPathFactory, load_script: Callable[[Path], ModuleType]) -> Path:
    """Reference files of elevator: its three baselines as run now, and `qlearning`, two synthetic seeds."""
    root = tmp_path_factory.mktemp("refs")
    result = gym4real.benchmark(ENV, ["random", "longest_first", "shortest_first"], episodes="test")
    rows = []
    for name in result.returns:
        for i, (objective, ret) in enumerate(zip(result.objective_values(name), result.returns[name], strict=True)):
            rows.append({"policy": name, "seed": None, "episode": i, "objective": objective, "return": ret})
    best = np.asarray(result.objective_values("longest_first"))
    for seed, shift in ((0, -500.0), (1, 300.0)):
        for i, value in enumerate(best + shift):
            rows.append({"policy": "qlearning", "seed": seed, "episode": i, "objective": value, "return": value})
    folder = root / "results" / "elevator-v0-paper"
    folder.mkdir(parents=True)
    pd.DataFrame(rows).to_csv(folder / "episodes.csv", index=False)
    provenance = {"code_version": "v1.0-3-gabc1234", "versions": {"gym4real-core": "0.2.0"}, "platform": "Linux"}
    (folder / "report.json").write_text(json.dumps({"env_id": ENV, "budget": "paper", **provenance}))
    export = load_script(Path(__file__).resolve().parents[1] / "scripts" / "export_references.py")
    assert export.main([str(root / "results"), "--into", str(root / "reference")]) == 0  # finds elevator's table
    return root / "reference"


def test_the_best_rule_scores_exactly_one_random_zero_and_itself_one_half(references: Path) -> None:
    evaluation = gym4real.evaluate(
        {"same": "longest_first", "rnd": "random"}, [ENV], references=references, headroom=False
    )
    score = evaluation.score()
    same, rnd = score["agents"]["same"], score["agents"]["rnd"]
    assert same["aggregate"]["iqm"] == 1.0 and same["envs"][ENV]["normalized_iqm"] == 1.0
    assert rnd["aggregate"]["iqm"] == 0.0 and rnd["envs"][ENV]["normalized_iqm"] == 0.0
    assert same["aggregate"]["shortfall"] == 0.0 and rnd["aggregate"]["shortfall"] == 1.0
    assert same["envs"][ENV]["probability_of_improvement"]["longest_first"] == 0.5
    assert set(same["envs"][ENV]["probability_of_improvement"]) == {"qlearning", "longest_first"}
    # the reference agent's own suite score: IQM over its seeds of each seed's normalised IQM
    ref = load_reference(ENV, references)
    assert ref is not None
    assert ref.manifest == {  # the provenance of the results section the reference runs come from
        "code_version": "v1.0-3-gabc1234",
        "versions": {"gym4real-core": "0.2.0"},
        "platform": "Linux",
    }
    low, top = (
        sps.trim_mean(ref.scores["random"], 0.25, axis=None),
        sps.trim_mean(ref.scores["longest_first"], 0.25, axis=None),
    )
    per_seed = (sps.trim_mean(ref.scores["qlearning"], 0.25, axis=1) - low) / (top - low)
    assert score["references"]["qlearning"]["iqm"] == pytest.approx(sps.trim_mean(per_seed, 0.25))
    table = evaluation.table()
    assert "qlearning                reference" in table and f"reference runs: paper budget, {ref.source}" in table


def test_without_agents_only_the_reference_agents_are_scored(references: Path) -> None:
    score = gym4real.evaluate({}, [ENV], references=references, headroom=False).score()
    assert score["agents"] == {} and list(score["references"]) == ["qlearning"]
    assert score["references"]["qlearning"]["runs"] == 2  # its two seeds


def test_a_changed_env_version_is_refused(references: Path, tmp_path: Path) -> None:
    changed = tmp_path / "reference"
    changed.mkdir()
    (changed / "elevator-v0.csv").write_bytes((references / "elevator-v0.csv").read_bytes())
    record = json.loads((references / "elevator-v0.json").read_text())
    assert record["budget"] == "paper" and record["manifest"]["code_version"] == "v1.0-3-gabc1234"
    assert record["fingerprint"]["episodes"] == 30 and record["fingerprint"]["fidelity"] == "corrected"
    installed = record["fingerprint"]["version"]
    record["fingerprint"]["version"] = "0.0.1"
    (changed / "elevator-v0.json").write_text(json.dumps(record))
    with pytest.raises(ReferenceMismatchError, match=f"version: '0.0.1' in the reference, '{installed}' installed"):
        gym4real.evaluate({"mine": "longest_first"}, [ENV], references=changed, headroom=False)


def test_a_user_module_factory_per_seed_from_the_cli_with_the_shipped_references(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "my_agents.py").write_text(
        textwrap.dedent(
            """
            from gym4real.elevator.baselines import longest_first, shortest_first

            SEEDS = []

            def make_policy(env, seed):
                SEEDS.append(seed)
                return longest_first(env) if seed == 0 else shortest_first(env)
            """
        )
    )
    monkeypatch.chdir(tmp_path)  # the module is found in the working folder, as the CLI promises
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "out"
    status = main(
        ["evaluate", "mine=my_agents:make_policy", "--envs", ENV, "--seeds", "0,7", "--out", str(out), "--no-headroom"]
    )
    assert status == 0
    import my_agents  # type: ignore[import-not-found]

    assert my_agents.SEEDS == [0, 7]
    printed = capsys.readouterr().out
    assert "(reference runs: paper budget" in printed  # the elevator's, shipped with its distribution
    assert "qlearning" in printed and "sarsa" in printed  # the paper agents beside the user's
    score = json.loads((out / "score.json").read_text())
    assert score["envs"][ENV]["seeds"] == 2 and score["aggregate"]["runs"] == 2
    assert score["scales"][ENV]["best_rule_based"] == "longest_first"
    # seed 0 is the best rule (1), seed 7 the other rule (below 1): the shortfall below the best rule is seed 7's / 2
    runs = pd.read_csv(out / "episodes.csv")
    mine = runs[runs["policy"] == "mine"]
    assert set(mine["seed"]) == {0, 7} and len(mine) == 2 * 30
    shortfall = 1 - sps.trim_mean(mine[mine["seed"] == 7]["normalized"], 0.25)
    assert score["aggregate"]["shortfall"] == pytest.approx(shortfall / 2)
    assert {"aggregate_intervals.png", "performance_profile.png", "report.md", "agent_episodes.csv"} <= {
        p.name for p in out.iterdir()
    }
    assert "| `mine` | agent | 1 | 2 |" in (out / "report.md").read_text()


def test_a_seed_asked_of_a_single_model_or_policy_object_is_refused(references: Path) -> None:
    with pytest.raises(ConfigError, match="names no `\\{seed\\}`"):
        gym4real.evaluate({"m": "sb3:a2c:model.zip"}, [ENV], seeds=[0, 1], references=references, headroom=False)
    with pytest.raises(PolicyError, match="takes no `seed`"):
        gym4real.evaluate({"m": lambda obs: 0}, [ENV], seeds=[0, 1], references=references, headroom=False)


def test_seeds_as_a_number_are_the_first_seeds_of_each_envs_plan_as_reproduce_trains_them(
    references: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`seeds=2` scores the models of `gym4real reproduce ... --seeds 2` (elevator: the paper's 42, then 0)."""
    from gym4real.bench.seeds import seeds as plan_seeds
    from gym4real.elevator.baselines import longest_first

    called: list[int] = []

    def factory(env: object, seed: int) -> object:
        called.append(seed)
        return longest_first(env)

    # no upper reference run here (headroom=False): the hindsight planner's plans are not what this checks
    evaluation = gym4real.evaluate({"mine": factory}, [ENV], seeds=2, references=references, headroom=False)
    assert called == plan_seeds(ENV, "paper", 2) == [42, 0]
    assert evaluation.score()["envs"][ENV]["seeds"] == 2
    path = "qlearning:runs/{env}/qlearning-paper-seed{seed}/qtable.npz"  # as `gym4real train` names its folders
    assert main(["evaluate", f"q={path}", "--envs", ENV, "--seeds", "1", "--no-headroom", "--out", str(tmp_path)]) == 2
    assert "runs/elevator-v0/qlearning-paper-seed42/qtable.npz" in capsys.readouterr().err  # the paper's seed


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ([{"policy": "a", "seed": 0, "episode": 0, "return": 1.0}], "no column"),
        (
            [
                {"policy": "a", "seed": 0, "episode": 0, "objective": 1.0, "return": 1.0},
                {"policy": "a", "seed": None, "episode": 0, "objective": 1.0, "return": 1.0},
            ],
            "with and without a seed",
        ),
        (
            [
                {"policy": "a", "seed": 0, "episode": 0, "objective": 1.0, "return": 1.0},
                {"policy": "a", "seed": 1, "episode": 1, "objective": 1.0, "return": 1.0},
            ],
            "one row per seed and test episode",
        ),
        ([{"policy": "a", "seed": None, "episode": 0, "objective": float("nan"), "return": 1.0}], "non-finite"),
    ],
)
def test_a_malformed_reference_table_is_refused(rows: list[dict[str, object]], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        score_matrices(pd.DataFrame(rows), "ref.csv")


@pytest.mark.slow
def test_the_tutorial_trains_a2c_on_two_envs_and_reads_its_score(
    tmp_path: Path, load_script: Callable[[Path], ModuleType]
) -> None:
    pytest.importorskip("stable_baselines3")
    tutorial = load_script(Path(__file__).resolve().parents[1] / "examples" / "evaluate_a2c.py")
    score = tutorial.main(["--steps", "300", "--seeds", "0", "--out", str(tmp_path)])
    aggregate = score["aggregate"]
    # trading's anchors are not told apart (its scale is noise): the suite score is wds's alone
    assert score["envs"]["gym4real/trading-v0"]["scale"]["separated"] is False
    assert aggregate["envs"] == ["gym4real/wds-v0"] and aggregate["runs"] == 1
    assert aggregate["low"] <= aggregate["iqm"] <= aggregate["high"] and np.isfinite(aggregate["shortfall"])
    for env_id in tutorial.TRAINING:
        assert score["envs"][env_id]["seeds"] == 1 and (tmp_path / "models" / env_id.split("/")[1] / "seed0").is_dir()
    assert json.loads((tmp_path / "score" / "score.json").read_text())["aggregate"] == aggregate


def test_bench_runs_a_user_module_factory_and_names_a_module_it_cannot_import(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "bench_agents.py").write_text("def always_up(env):\n    return lambda obs: 1\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    args = ["bench", ENV, "--episodes", "1", "--quiet", "--out", str(tmp_path / "out")]
    assert main([*args, "--policies", "bench_agents:always_up"]) == 0
    assert "bench_agents:always_up" in pd.read_csv(tmp_path / "out" / "summary.csv")["policy"].tolist()
    assert main([*args, "--policies", "no_such_module:factory"]) == 2
    assert "cannot import `no_such_module:factory`" in capsys.readouterr().err


def test_an_env_without_reference_runs_is_compared_with_its_baselines_run_now(tmp_path: Path) -> None:
    evaluation = gym4real.evaluate({"mine": "flat"}, ["gym4real/trading-v0"], references=tmp_path)  # none there
    assert f"none in `{tmp_path}`: compared with the baselines run now" in evaluation.table()
    assert evaluation.references() == []
    entry = evaluation.score()["envs"]["gym4real/trading-v0"]
    # the baselines run now measure the scale too: buy_and_hold does not beat random beyond the noise
    assert entry["scale"]["one"] == "buy_and_hold" and entry["scale"]["separated"] is False
    assert entry["normalized_iqm"] is None


def test_an_unknown_id_is_named_with_the_nearest_ones(capsys: pytest.CaptureFixture[str]) -> None:
    for command in (["evaluate", "flat", "--envs", "gym4real/elevator-v9"], ["bench", "gym4real/elevator-v9"]):
        assert main(command) == 2
        err = capsys.readouterr().err
        assert "unknown environment `gym4real/elevator-v9`. Did you mean `gym4real/elevator-v0`" in err, err
        assert "evaluation protocol" not in err


@pytest.mark.slow
def test_a_deterministic_agent_over_three_seeds_gets_a_suite_interval_of_nonzero_width(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the same rule for every seed: the seeds do not differ, only the test episodes do (issue 32)
    (tmp_path / "steady_agents.py").write_text(
        textwrap.dedent(
            """
            from gym4real.bench.policies import make_policy

            def steady(env, seed):
                env_id = env.spec.id if env.spec is not None else ""
                return make_policy(env_id, "mean" if "dam" in env_id else "p79", env)
            """
        )
    )
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    envs = "gym4real/dam-v0,gym4real/wds-v0"
    out = tmp_path / "out"
    command = ["evaluate", "mine=steady_agents:steady", "--envs", envs, "--seeds", "0,1,2", "--out", str(out)]
    assert main([*command, "--no-headroom"]) == 0  # the upper references' runs are not what this checks
    score = json.loads((out / "score.json").read_text())
    episodes = pd.read_csv(out / "episodes.csv")
    mine = episodes[episodes["policy"] == "mine"]
    for env_id in envs.split(","):
        entry = score["envs"][env_id]
        assert entry["seeds"] == 3 and entry["scale"]["separated"] is True
        low, high = entry["scale"]["difference"]
        assert 0 < low <= high
        per_seed = mine[mine["env_id"] == env_id].pivot(index="seed", columns="episode", values="objective")
        assert (per_seed.nunique(axis=0) == 1).all()  # deterministic: every seed scores alike on each episode
    aggregate = score["aggregate"]
    assert aggregate["runs"] == 6 and aggregate["high"] - aggregate["low"] > 0.01
    assert aggregate["low"] <= aggregate["iqm"] <= aggregate["high"]


def test_trading_whose_anchors_are_not_separated_stays_out_of_the_suite_score() -> None:
    agent = {"gym4real/trading-v0": "flat", ENV: "longest_first"}
    evaluation = gym4real.evaluate({"mine": agent}, ["gym4real/trading-v0", ENV])  # the shipped reference runs
    score = evaluation.score()
    trading = "gym4real/trading-v0"
    entry = score["envs"][trading]
    scale = entry["scale"]
    assert scale["zero"] == "random" and scale["one"] == "buy_and_hold" and scale["separated"] is False
    low, high = scale["difference"]
    assert low < 0 < high  # buy_and_hold - random: within the noise of the test days
    reference = load_reference(trading)
    assert reference is not None
    estimate = sps.trim_mean(reference.scores["buy_and_hold"], 0.25, axis=None) - sps.trim_mean(
        reference.scores["random"], 0.25, axis=None
    )
    assert low < estimate < high and f"{estimate:,.4g}" in score["scales"][trading]["note"]
    assert entry["normalized_iqm"] is None and score["scales"][trading]["separated"] is False
    assert score["aggregate"]["envs"] == [ENV]
    assert all(trading not in agg["envs"] for agg in score["references"].values())
    assert "no normalised scale: no rule-based baseline beats `random` with a 95 % interval" in evaluation.table()


def test_the_aggregate_figure_draws_a_point_interval_as_the_agents_marker_inside_the_axes() -> None:
    from matplotlib.lines import Line2D

    from gym4real.bench.evaluate_report import AGENT_COLOUR, aggregate_figure

    point = {"iqm": -0.286, "low": -0.286, "high": -0.286}  # a zero-width interval, below every other bound
    point.update(shortfall=1.286, shortfall_low=1.286, shortfall_high=1.286)
    wide = {"iqm": 0.7, "low": 0.629, "high": 0.7, "shortfall": 0.3, "shortfall_low": 0.3}
    wide["shortfall_high"] = 0.371
    fig = aggregate_figure({"mine": point, "a2c": wide}, ["mine"])
    fig.canvas.draw()
    for ax, key in zip(fig.axes, ("iqm", "shortfall"), strict=True):
        markers = [
            line for line in ax.get_lines() if isinstance(line, Line2D) and line.get_marker() not in ("None", None, "")
        ]
        mine = [m for m in markers if m.get_label() == "your agent"]
        assert len(mine) == 1 and mine[0].get_color() == AGENT_COLOUR
        x, y = mine[0].get_xdata()[0], mine[0].get_ydata()[0]
        assert x == point[key]
        left, right = ax.get_xlim()
        assert min(left, right) < x < max(left, right)  # inside, not on the axis line
        shown = ax.transData.transform((x, y))
        box = ax.get_window_extent()
        assert box.x0 < shown[0] < box.x1 and box.y0 < shown[1] < box.y1
        bounds = ("low", "high") if key == "iqm" else ("shortfall_low", "shortfall_high")
        every = [row[k] for row in (point, wide) for k in (key, *bounds)]
        assert all(min(left, right) < v < max(left, right) for v in every)  # axes that include every point
    labels = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert labels == ["mine (your agent)", "a2c"]
    assert fig.axes[0].get_yticklabels()[0].get_fontweight() == "bold"
