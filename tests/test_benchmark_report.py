"""What the benchmark shows a person: one score (the objective), the protocol run, labels, one number format,
notes on the columns, figure axes and legends."""

from __future__ import annotations

import json
import re
from pathlib import Path

import matplotlib.figure
import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

import gym4real
from gym4real.bench import plots
from gym4real.bench.benchmark import FEW_EPISODES, BenchmarkResult, benchmark, protocol, short_label
from gym4real.bench.upper_label import label
from gym4real.cli import main
from gym4real.core.registry import registry
from gym4real.results import analysis


def result_of(
    returns: dict[str, list[float]], objective: tuple[str, ...] = (), env_id: str = "gym4real/elevator-v0"
) -> BenchmarkResult:
    """A result whose episodes each have one step, the whole return (components: ``a`` a quarter, ``b`` the rest)."""
    n = len(next(iter(returns.values())))
    result = BenchmarkResult(env_id, [{"seed": i} for i in range(n)], objective=objective)
    for name, rets in returns.items():
        result.returns[name] = rets
        result.rewards[name] = [np.array([r]) for r in rets]
        result.components[name] = {"a": [r / 4 for r in rets], "b": [3 * r / 4 for r in rets]}
        if objective:
            result.objective_rewards[name] = [
                np.array([sum(result.components[name][c][i] for c in objective)]) for i in range(n)
            ]
    return result


def rows_of(table: str) -> list[list[str]]:
    """The table's rows (below its protocol lines, its header and its index name), cells split."""
    lines = table.splitlines()
    start = lines.index("") + 3  # the protocol, a blank line, the header, the index name
    return [line.split() for line in lines[start:] if line and not line.startswith("  ")]


def numbers(table: str) -> list[str]:
    return [cell for row in rows_of(table) for cell in row[2:]]


def test_a_table_uses_one_number_format() -> None:
    table = result_of({"big": [-46_000.0, -45_500.0] * 6, "small": [2856.0, 2857.5] * 6}).table()
    cells = numbers(table)
    assert len(cells) == 2 * 5 and not any("e" in c for c in cells), table
    assert len({len(c.rpartition(".")[2]) if "." in c else 0 for c in cells}) == 1, table  # same decimals


def test_the_table_ranks_by_the_objective_and_labels_the_return_as_the_training_reward() -> None:
    # `a` (the objective) is a quarter of the return: the ranking follows the objective, here the same order
    result = result_of({"low": [1.0, 2.0] * 6, "high": [10.0, 12.0] * 6}, objective=("a",))
    table = result.table()
    head = table.splitlines()[result.table().splitlines().index("") + 1].split()
    assert head[:6] == [
        "episodes",
        "objective_iqm",
        "objective_low",
        "objective_high",
        "objective_mean",
        "objective_std",
    ]
    assert "return_mean" in head
    assert [row[0] for row in rows_of(table)] == ["high", "low"]
    assert "objective_iqm: interquartile mean of the per-episode objective (a), the score" in table
    assert "return_mean: mean episode return (training reward), not the score" in table
    assert result.summary().loc["high", "objective_iqm"] == sps.trim_mean([2.5, 3.0] * 6, 0.25)


def test_an_objective_that_is_the_return_is_said_once() -> None:
    result = result_of({"p": [1.0, 2.0] * 6}, objective=("a", "b"))  # a + b is the whole return
    assert result.objective_is_return
    table = result.table()
    assert "objective (the score): the episode return (training reward) itself" in table
    assert "return_mean" not in table and "return_mean" not in result.summary()


def test_the_ranking_is_by_the_iqm_not_the_mean() -> None:
    # `skewed` has the better mean (one huge episode) but the worse IQM: the score is the IQM
    result = result_of({"skewed": [0.0] * 11 + [1000.0], "steady": [1.0] * 12})
    assert result.ranking() == ["steady", "skewed"]
    assert list(result.summary()["rank"]) == [1, 2]


def test_few_episodes_warn_that_the_ci_and_iqm_mean_little() -> None:
    few = result_of({"p": [1.0, 2.0]}).table()
    enough = result_of({"p": [float(i) for i in range(FEW_EPISODES)]}).table()
    assert f"warning: 2 episode(s) per policy: bootstrap CIs and the IQM mean little below {FEW_EPISODES}" in few
    assert "warning" not in enough


def test_a_model_file_is_labelled_by_its_run_folder() -> None:
    run = "qlearning:runs/gym4real_elevator-v0/qlearning-paper-seed0/qtable.npz"
    assert short_label(run) == "qlearning-paper-seed0"
    assert short_label("ppo:models/best.zip") == "ppo:best"
    assert short_label("longest_first") == "longest_first"


def test_a_trained_model_is_benchmarked_under_its_short_label(tmp_path: Path, monkeypatch) -> None:
    from gym4real.rl.train import train

    monkeypatch.chdir(tmp_path)
    model = train("gym4real/elevator-v0", "qlearning", "smoke", seed=3).model_path
    ref = f"qlearning:{model}"
    out = tmp_path / "bench"
    result = gym4real.benchmark("gym4real/elevator-v0", ["longest_first", ref], episodes=1, out=out)
    assert set(result.summary().index) == {"longest_first", "qlearning-smoke-seed3"}
    assert "qlearning-smoke-seed3" in [row[0] for row in rows_of(result.table())]
    record = json.loads((out / "results.json").read_text())
    assert record["labels"][ref] == "qlearning-smoke-seed3" and ref in record["returns"]


def test_policies_whose_curves_coincide_are_told_apart() -> None:
    result = result_of({"p78": [1.0, 2.0, 3.0], "p79": [1.0, 2.0 + 1e-7, 3.0], "other": [5.0, 6.0, 7.0]})
    curves = plots.mean_curves(result)
    assert list(curves) == ["other", "p79", "p78"]  # best first
    legend = plots.legend_labels(result, curves)
    assert legend == {"other": "other", "p79": "p79", "p78": "p78 (overlaps p79)"}


def test_the_upper_reference_is_drawn_apart_and_never_ranked_first_in_the_bench_figures(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    drawn: dict[str, matplotlib.figure.Figure] = {}
    save = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(
        matplotlib.figure.Figure,
        "savefig",
        lambda fig, path, **kw: drawn.setdefault(Path(path).name, fig) and save(fig, path, **kw),
    )
    # hindsight (dam's non-causal upper reference) scores best, yet is not ranked among the baselines
    result = result_of({"hindsight": [9.0, 9.5], "max": [5.0, 6.0], "ead": [1.0, 2.0]}, env_id="gym4real/dam-v0")
    assert result.ranking()[0] == "hindsight" and plots.plotted_order(result) == ["max", "ead", "hindsight"]
    plots.save_figures(result, tmp_path)
    curves = drawn["cumulative_reward.png"].axes[0]
    legend = curves.get_legend()
    dam_hindsight = label("gym4real/dam-v0", "hindsight")  # hindsight (non-causal upper reference, heuristic, ...)
    assert dam_hindsight.startswith("hindsight (non-causal upper reference, heuristic")
    assert [t.get_text() for t in legend.get_texts()] == ["max", "ead", dam_hindsight]
    assert "upper reference last" in legend.get_title().get_text()
    means = {line.get_label(): line for line in curves.get_lines() if not line.get_label().startswith("_")}
    upper = means.pop(dam_hindsight)
    assert upper.get_marker() == plots.UPPER_MARKER and upper.get_color() == plots.UPPER_COLOUR
    assert all(line.get_marker() != plots.UPPER_MARKER and line.get_color() != "black" for line in means.values())
    box = drawn["returns_boxplot.png"].axes[0]
    ticks = [t.get_text() for t in box.get_xticklabels()]
    assert ticks == ["max", "ead", dam_hindsight.replace(" (", "\n(", 1).replace(", ", ",\n", 1)]
    assert "not ranked" in box.get_xlabel()
    hatches = [patch.get_hatch() for patch in box.patches]
    assert hatches == [None, None, "//"]  # only the upper reference's box is hatched


def test_figures_name_the_step_unit_and_keep_the_legend_off_the_plot(tmp_path: Path, monkeypatch) -> None:
    drawn: dict[str, matplotlib.figure.Figure] = {}
    save = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(
        matplotlib.figure.Figure,
        "savefig",
        lambda fig, path, **kw: drawn.setdefault(Path(path).name, fig) and save(fig, path, **kw),
    )
    result = gym4real.benchmark(
        "gym4real/elevator-v0", ["longest_first", "random"], episodes=2, env_kwargs={"duration": 60}
    )
    assert result.step_unit == "second"  # the elevator's protocol: one step is one second
    result.save(tmp_path)
    ax = drawn["cumulative_reward.png"].axes[0]
    assert ax.get_xlabel() == "second"
    legend = ax.get_legend().get_window_extent()
    assert legend.x0 >= ax.get_window_extent().x1  # beside the axes, over no band
    assert drawn["returns_boxplot.png"].axes[0].get_xlabel() == "policy (best first by IQM)"
    assert re.fullmatch(r"\w+", json.loads((tmp_path / "results.json").read_text())["step_unit"])


def test_the_per_step_objective_adds_up_to_the_episodes_objective_and_is_what_reproduce_plots(tmp_path: Path) -> None:
    from gym4real.bench.benchmark import benchmark

    result = benchmark("gym4real/dam-v0", ["max"], episodes=1)
    steps = result.objective_rewards["max"][0]
    assert len(steps) == len(result.rewards["max"][0])
    assert np.isclose(steps.sum(), result.objective_values("max")[0])
    assert not np.isclose(steps.sum(), result.returns["max"][0])  # dam's reward has more than the objective
    curves = plots.mean_curves(result)
    assert np.isclose(curves["max"][0][-1], result.objective_values("max")[0])


def test_bench_of_dam_ranks_max_above_ead_by_the_objective_names_it_and_plots_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    drawn: dict[str, matplotlib.figure.Figure] = {}
    save = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(
        matplotlib.figure.Figure,
        "savefig",
        lambda fig, path, **kw: drawn.setdefault(Path(path).name, fig) and save(fig, path, **kw),
    )
    assert main(["bench", "gym4real/dam-v0", "--policies", "ead,max", "--out", str(tmp_path), "--quiet"]) == 0
    out = capsys.readouterr().out
    head, table = out.split("\n\n", 1)
    assert "gym4real/dam-v0, test protocol: the 13 test years" in head
    assert "13 episode(s) per policy, reset seeds" in head and "preset=test" in head
    assert "objective (the score): deficit + overflow + starving per episode, higher is better" in head
    rows = [line.split()[0] for line in table.splitlines()[2:4]]
    assert rows == ["max", "ead"]  # by the objective, max is better; by the return, ead would be (issue 32)
    episodes = pd.read_csv(tmp_path / "episodes.csv")
    objective = episodes.groupby("policy")["objective"].apply(lambda v: sps.trim_mean(v, 0.25))
    returns = episodes.groupby("policy")["return"].mean()
    assert objective["max"] > objective["ead"] and returns["ead"] > returns["max"]
    summary = pd.read_csv(tmp_path / "summary.csv", index_col="policy")
    assert list(summary.index) == ["max", "ead"]
    assert summary.loc["max", "objective_iqm"] == pytest.approx(objective["max"])
    assert json.loads((tmp_path / "results.json").read_text())["ranking"] == ["max", "ead"]
    curves = drawn["cumulative_reward.png"].axes[0]
    assert curves.get_ylabel() == "cumulative objective (deficit + overflow + starving)"
    assert "13 test episodes" in curves.get_title()
    first = curves.get_lines()[0]  # the best policy's mean curve ends at its mean objective
    assert first.get_label() == "max"
    assert first.get_ydata()[-1] == pytest.approx(episodes.loc[episodes["policy"] == "max", "objective"].mean())
    box = drawn["returns_boxplot.png"].axes[0]
    assert [t.get_text() for t in box.get_xticklabels()] == ["max", "ead"]
    assert box.get_ylabel() == "episode objective (deficit + overflow + starving)"


#: Every env with a test protocol, each benchmarked on a few short episodes.
PROTOCOL_ENVS = [e for e in gym4real.list_envs(multi_objective=False) if e in registry().benchmarks]


@pytest.mark.parametrize("env_id", PROTOCOL_ENVS)
def test_every_env_bench_ranks_as_evaluate_and_the_results_page(env_id: str) -> None:
    spec = protocol(env_id)
    kwargs = {**spec.env_kwargs, "max_episode_steps": 24}
    result = benchmark(env_id, episodes=3, env_kwargs=kwargs)
    frame = result.per_episode()
    # the objective, recomputed from the reward components (the return where the protocol names none)
    recomputed = frame[list(spec.objective)].sum(axis=1) if spec.objective else frame["return"]
    np.testing.assert_allclose(frame["objective"], recomputed, rtol=1e-12)
    # the results page's statistics (and evaluate's: the IQM of the objective over the test episodes)
    page = analysis.summary(frame.assign(seed=None)[["policy", "seed", "episode", "objective", "return"]])
    page_iqm = page.set_index("policy")["iqm"]
    by_hand = frame.assign(objective=recomputed).groupby("policy")["objective"].apply(lambda v: sps.trim_mean(v, 0.25))
    ranked = list(result.summary().index)
    assert ranked == [result.labels[n] for n in result.ranking()]
    assert sorted(ranked) == sorted(page_iqm.index)
    iqms = [page_iqm[p] for p in ranked]
    assert iqms == sorted(iqms, reverse=True), (ranked, iqms)
    np.testing.assert_allclose(result.summary()["objective_iqm"], page_iqm[ranked], rtol=1e-12)
    np.testing.assert_allclose(by_hand[ranked], page_iqm[ranked], rtol=1e-12)
