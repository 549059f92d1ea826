"""Evaluation protocol, the core benchmark on a few episodes and the package's extra figures."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gym4real.bench.benchmark import benchmark
from gym4real.robofeeder import figures
from gym4real.robofeeder.evaluation import planning_test_episodes
from gym4real.robofeeder.evaluation import test_episodes as protocol


def test_protocol_sizes() -> None:
    assert len(protocol({"preset": "test"})) == 100
    plan = planning_test_episodes({"preset": "test"})
    assert len(plan) == 50 and plan[0] == {"seed": 1000, "options": None}


def test_core_benchmark_runs(tmp_path: Path) -> None:
    result = benchmark("gym4real/robofeeder-picking-v0", ["fixed", "oracle"], episodes=3, out=tmp_path)
    summary = result.summary()
    assert summary.loc["oracle", "objective_mean"] > summary.loc["fixed", "objective_mean"]
    assert (tmp_path / "cumulative_reward.png").is_file() and (tmp_path / "returns_boxplot.png").is_file()


def test_extra_figures(tmp_path: Path) -> None:
    paths = figures.picking_heatmap(tmp_path, ["oracle"], grid=2, seeds=1)
    assert all(p.is_file() and p.stat().st_size > 0 for p in paths)
    rows = paths[1].read_text().splitlines()
    assert rows[0] == "policy,x,y,success_rate,reachable" and len(rows) == 5
    paths = figures.planning_returns(tmp_path, ["random"], objects=[1, 2], episodes=1, seeds=2)
    assert all(p.is_file() for p in paths)
    assert len(paths[1].read_text().splitlines()) == 1 + 2 * 2


def test_bench_draws_the_papers_figures(tmp_path: Path) -> None:
    import gym4real

    gym4real.benchmark("gym4real/robofeeder-planning-v0", ["random"], episodes=1, out=tmp_path)
    assert (tmp_path / "planning_returns.png").stat().st_size > 0
    rows = (tmp_path / "planning_returns.csv").read_text().splitlines()
    assert len(rows) == 1 + 5 * 5  # 1 episode per point, 5 object counts, 5 seeds


def test_each_test_episodes_object_lies_in_the_spawn_area_where_its_seed_puts_it() -> None:
    from gym4real.robofeeder.config import SpawnSection
    from gym4real.robofeeder.evaluation import test_placements

    found = np.array(test_placements({"preset": "test"}))
    assert found.shape == (100, 2) and len({tuple(p) for p in found.round(3)}) == 100  # a position per seed
    spawn, half = SpawnSection(), 300 / 2  # the test preset's 300-px image
    lo = (np.array([spawn.x_range[0], spawn.y_range[0]]) + 1) * half
    hi = (np.array([spawn.x_range[1], spawn.y_range[1]]) + 1) * half
    settle = 15.0  # px: the silhouette's centre lies off the placed origin, and the part settles on the floor
    assert np.all(found >= lo - settle) and np.all(found <= hi + settle)
    again = np.array(test_placements({"preset": "test"})[:1])
    assert np.array_equal(again, found[:1])  # the same seed places the object at the same place
