"""The paper's RoboFeeder figures (beyond the core benchmark's two).

* :func:`picking_heatmap`: success rate of picking-v0 policies over a grid of object placements in the
  image (the reference notebook ``picking_performance.ipynb``: a 10 x 10 grid of normalised image
  coordinates in [-0.8, 0.8], 5 orientation seeds, one object, one attempt), drawn over the camera frame.
  The grid extends beyond the arm's reach (the lower image rows, more than about 0.59 m from the robot's
  axis): those cells are hatched, and the mean is also given over the reachable cells.
* :func:`planning_returns`: mean return of planning policies vs the number of objects in the bin
  (the paper: 50 episodes x 5 seeds per point).

``gym4real bench`` draws them through the protocol's figures hooks (:func:`bench_heatmap`,
:func:`bench_planning`), for the policies it benchmarked; both write a PNG and a CSV. They draw with
matplotlib, which the harness brings (the ``bench`` extra of gym4real-core), not this distribution: the
environments never import this module.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gym4real.bench.benchmark import short_label
from gym4real.robofeeder._plugin import PICKING_V0, PLANNING_V0

if TYPE_CHECKING:
    from gym4real.bench.benchmark import BenchmarkResult


def _policy(env_id: str, name: str, env: Any) -> Any:
    from gym4real.bench.policies import make_policy

    return make_policy(env_id, name, env)


def heatmap_rates(
    policy: str, grid: int = 10, seeds: int = 5, extent: float = 0.8, env_kwargs: dict[str, Any] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Success rate of ``policy`` on picking-v0 per placement of a single object.

    Returns:
        (rates (grid x grid, rows = image y, columns = image x), the normalised coordinates of the grid).
    """
    import gymnasium as gym

    import gym4real  # noqa: F401  (registers the ids)

    coords = np.linspace(-extent, extent, grid)
    env = gym.make(PICKING_V0, **{"preset": "test", **(env_kwargs or {}), "n_objects": 1})
    try:
        act = _policy(PICKING_V0, policy, env)
        rates = np.zeros((grid, grid))
        for row, y in enumerate(coords):
            for col, x in enumerate(coords):
                wins = 0
                for seed in range(seeds):
                    if hasattr(act, "reset"):
                        act.reset(seed)
                    obs, _ = env.reset(seed=seed, options={"placements": [[x, y]]})
                    _, _, _, _, info = env.step(act(obs))
                    wins += bool(info["success"])
                rates[row, col] = wins / seeds
    finally:
        env.close()
    return rates, coords


def _workspace(coords: np.ndarray, env_kwargs: dict[str, Any] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The heat map's workspace, from one env.

    Returns whether the arm reaches each cell centre of the grid (rows = image y, columns = image x), and the
    empty bin seen by the top-down camera (objects out of view).
    """
    from gym4real.robofeeder.env import RoboFeederPickingEnv

    env = RoboFeederPickingEnv(preset="test", **(env_kwargs or {}))
    try:
        size = env.size
        reachable = np.array(
            [
                [
                    env.sim.arm_reaches(env.sim.camera.pixel_to_world((np.array([x, y]) + 1.0) * size / 2.0))
                    for x in coords
                ]
                for y in coords
            ]
        )
        env.reset(seed=0, options={"placements": [[0.0, 5.0]]})  # an object far outside the image
        return reachable, env.sim.render("top_down")
    finally:
        env.close()


def picking_heatmap(
    out: str | Path,
    policies: Sequence[str] = ("fixed", "oracle"),
    grid: int = 10,
    seeds: int = 5,
    env_kwargs: dict[str, Any] | None = None,
) -> list[Path]:
    """Write ``picking_heatmap.png`` (one panel per policy over the camera frame) and ``picking_heatmap.csv``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    results = {p: heatmap_rates(p, grid, seeds, env_kwargs=env_kwargs) for p in policies}
    coords = next(iter(results.values()))[1]
    reachable, frame = _workspace(coords, env_kwargs)
    size = frame.shape[0]
    fig, axes = plt.subplots(1, len(policies), figsize=(4.6 * len(policies), 4.4), squeeze=False)
    for ax, (name, (rates, coords)) in zip(axes[0], results.items(), strict=True):
        half = (coords[1] - coords[0]) / 2 if len(coords) > 1 else 0.1
        lo, hi = (coords[0] - half + 1) * size / 2, (coords[-1] + half + 1) * size / 2
        ax.imshow(frame, extent=(0, size, size, 0))
        im = ax.imshow(rates, extent=(lo, hi, hi, lo), cmap="viridis", vmin=0, vmax=1, alpha=0.6)
        cell = (hi - lo) / len(coords)
        for r, c in zip(*np.nonzero(~reachable), strict=True):
            ax.add_patch(Rectangle((lo + c * cell, lo + r * cell), cell, cell, fill=False, hatch="//", lw=0))
        within = f"{rates[reachable].mean():.2f}" if reachable.any() else "-"
        title = f"{short_label(name)}: mean success {rates.mean():.2f}\n{within} within reach (hatched: out of reach)"
        ax.set(xlim=(0, size), ylim=(size, 0), xlabel="image u (px)", ylabel="image v (px)")
        ax.set_title(title, fontsize=9)
    fig.colorbar(im, ax=axes[0].tolist(), label="success rate", shrink=0.8)
    fig.suptitle(f"{PICKING_V0}: picking success over the workspace\n({seeds} orientation seeds per cell)")
    png, table = out / "picking_heatmap.png", out / "picking_heatmap.csv"
    fig.savefig(png, dpi=110)
    plt.close(fig)
    with table.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["policy", "x", "y", "success_rate", "reachable"])
        for name, (rates, coords) in results.items():
            for r, y in enumerate(coords):
                for c, x in enumerate(coords):
                    writer.writerow([name, f"{x:.4f}", f"{y:.4f}", f"{rates[r, c]:.4f}", int(reachable[r, c])])
    return [png, table]


def planning_returns(
    out: str | Path,
    policies: Sequence[str] = ("random", "oracle"),
    objects: Sequence[int] = (1, 2, 3, 4, 5),
    episodes: int = 50,
    seeds: int = 5,
    env_kwargs: dict[str, Any] | None = None,
) -> list[Path]:
    """Write ``planning_returns.png`` (mean return +- 95 % CI vs objects) and ``planning_returns.csv``."""
    import gymnasium as gym
    import matplotlib

    import gym4real  # noqa: F401
    from gym4real.bench.benchmark import run_episode

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in policies:
        for n in objects:
            env = gym.make(PLANNING_V0, **{"preset": "test", **(env_kwargs or {}), "n_objects": n})
            try:
                act = _policy(PLANNING_V0, name, env)
                for seed in range(seeds):
                    for ep in range(episodes):
                        episode_seed = 10_000 * seed + ep
                        total = float(run_episode(env, act, episode_seed, None)["rewards"].sum())
                        rows.append((name, n, seed, ep, total))
            finally:
                env.close()
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for name in policies:
        means, lows, highs = [], [], []
        for n in objects:
            per_seed = [np.mean([r[4] for r in rows if r[0] == name and r[1] == n and r[2] == s]) for s in range(seeds)]
            m = float(np.mean(per_seed))
            half = 1.96 * float(np.std(per_seed, ddof=1)) / np.sqrt(seeds) if seeds > 1 else 0.0
            means.append(m)
            lows.append(m - half)
            highs.append(m + half)
        ax.plot(objects, means, marker="o", label=short_label(name))
        ax.fill_between(objects, lows, highs, alpha=0.25)
    ax.set(
        xlabel="objects in the bin",
        ylabel="mean episode return",
        title=f"{PLANNING_V0}\n{episodes} episodes x {seeds} seeds (95 % CI over seeds)",
    )
    ax.set_xticks(list(objects))
    ax.legend()
    fig.tight_layout()
    png, table = out / "planning_returns.png", out / "planning_returns.csv"
    fig.savefig(png, dpi=110)
    plt.close(fig)
    with table.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["policy", "n_objects", "seed", "episode", "return"])
        writer.writerows(rows)
    return [png, table]


def _named(result: BenchmarkResult) -> list[str]:
    """The result's policies that can be rebuilt by name (baselines and ``kind:path`` models)."""
    from gym4real.core.registry import baseline_names

    known = set(baseline_names(result.env_id))
    return [p for p in result.returns if p in known or ":" in p]


def bench_heatmap(result: BenchmarkResult, out: str | Path) -> list[Path]:
    """Benchmark figures hook of picking-v0: the heatmap of the benchmarked policies.

    The paper's 5 orientation seeds per cell on the 100-episode protocol; fewer for shorter benchmarks.
    """
    seeds = max(1, min(5, -(-len(result.episodes) // 20)))
    return picking_heatmap(out, _named(result), seeds=seeds)


def bench_planning(result: BenchmarkResult, out: str | Path) -> list[Path]:
    """Benchmark figures hook of planning: mean return vs objects, as many episodes per point as the benchmark."""
    return planning_returns(out, _named(result), episodes=min(50, len(result.episodes)))
