"""What the benchmark shows a person: labels, one number format, notes on the columns, figure axes and legends."""

from __future__ import annotations

import json
import re
from pathlib import Path

import matplotlib.figure
import numpy as np

import gym4real
from gym4real.core import plots
from gym4real.core.benchmark import FEW_EPISODES, BenchmarkResult, short_label


def result_of(returns: dict[str, list[float]], objective: tuple[str, ...] = ()) -> BenchmarkResult:
    """A result whose episodes each have one step, the whole return (components split it in two halves)."""
    n = len(next(iter(returns.values())))
    result = BenchmarkResult("gym4real/elevator-v0", [{"seed": i} for i in range(n)], objective=objective)
    for name, rets in returns.items():
        result.returns[name] = rets
        result.rewards[name] = [np.array([r]) for r in rets]
        result.components[name] = {"a": [r / 2 for r in rets], "b": [r / 2 for r in rets]}
    return result


def numbers(table: str) -> list[str]:
    rows = [line.split()[2:] for line in table.splitlines()[2:] if line and not line.startswith("  ")]
    return [cell for row in rows for cell in row]


def test_a_table_uses_one_number_format() -> None:
    table = result_of({"big": [-46_000.0, -45_500.0] * 6, "small": [2856.0, 2857.5] * 6}).table()
    cells = numbers(table)
    assert len(cells) == 2 * 5 and not any("e" in c for c in cells), table
    assert len({len(c.rpartition(".")[2]) if "." in c else 0 for c in cells}) == 1, table  # same decimals


def test_the_objective_column_is_explained() -> None:
    table = result_of({"p": [1.0, 2.0] * 6}, objective=("a", "b")).table()
    assert "objective_mean" in table.splitlines()[0]
    assert "objective_mean: mean per-episode sum of a + b" in table


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
    from gym4real.core.rl.train import train

    monkeypatch.chdir(tmp_path)
    model = train("gym4real/elevator-v0", "qlearning", "smoke", seed=3).model_path
    ref = f"qlearning:{model}"
    out = tmp_path / "bench"
    result = gym4real.benchmark("gym4real/elevator-v0", ["longest_first", ref], episodes=1, out=out)
    assert list(result.summary().index) == ["longest_first", "qlearning-smoke-seed3"]
    assert result.table().splitlines()[3].startswith("qlearning-smoke-seed3 ")
    record = json.loads((out / "results.json").read_text())
    assert record["labels"][ref] == "qlearning-smoke-seed3" and ref in record["returns"]


def test_policies_whose_curves_coincide_are_told_apart() -> None:
    result = result_of({"p78": [1.0, 2.0, 3.0], "p79": [1.0, 2.0 + 1e-7, 3.0], "other": [5.0, 6.0, 7.0]})
    legend = plots.legend_labels(result, plots.mean_curves(result))
    assert legend == {"p78": "p78", "p79": "p79 (overlaps p78)", "other": "other"}


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
    assert drawn["returns_boxplot.png"].axes[0].get_xlabel() == "policy"
    assert re.fullmatch(r"\w+", json.loads((tmp_path / "results.json").read_text())["step_unit"])


def test_the_per_step_objective_adds_up_to_the_episodes_objective_and_is_what_reproduce_plots(tmp_path: Path) -> None:
    from gym4real.core.benchmark import benchmark

    result = benchmark("gym4real/dam-v0", ["max"], episodes=1)
    steps = result.objective_rewards["max"][0]
    assert len(steps) == len(result.rewards["max"][0])
    assert np.isclose(steps.sum(), result.objective_values("max")[0])
    assert not np.isclose(steps.sum(), result.returns["max"][0])  # dam's reward has more than the objective
    curves = plots.mean_curves(result, objective=True)
    assert np.isclose(curves["max"][0][-1], result.objective_values("max")[0])
