"""``gym4real reproduce``: train (or load) the paper's agent and benchmark it against the baselines."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gym4real.core.benchmark import benchmark, protocol
from gym4real.core.registry import registry
from gym4real.core.rl.train import default_out, train


def reproduce(
    env_id: str, preset: str = "paper", seed: int = 0, out: str | Path | None = None, progress: bool = False
) -> str:
    """Train every registered algorithm of ``preset`` (or reuse a saved model) and benchmark on the test protocol.

    Returns the summary table followed by the paper's qualitative claim, checked: each RL agent's mean
    objective is above every baseline's.
    """
    algos = sorted(a for (e, a, p) in registry().trainings if e == env_id and p == preset)
    folder = Path(out) if out else Path("results") / f"reproduce-{env_id.replace('/', '_')}-{preset}"
    agents = []
    for algo in algos:
        run_dir = default_out(env_id, algo, preset, seed)
        model = run_dir / ("qtable.npz" if algo in ("qlearning", "sarsa") else "model.zip")
        if not model.exists():
            model = train(env_id, algo, preset, seed, run_dir, progress).model_path
        agents.append(f"{algo}:{model}")
    baselines = list(protocol(env_id).policies)
    result = benchmark(env_id, [*baselines, *agents], episodes="test", progress=progress, out=folder)
    means = {name: float(np.mean(result.objective_values(name))) for name in result.returns}
    lines = [result.table(), ""]
    best_baseline = max(means[b] for b in baselines)
    for agent in agents:
        verdict = "holds" if means[agent] > best_baseline else "does NOT hold"
        lines.append(
            f"paper claim: {agent.split(':')[0]} above every baseline "
            f"({means[agent]:.4g} vs best baseline {best_baseline:.4g}): {verdict}"
        )
    lines.append(f"results and figures in {folder}/")
    report = "\n".join(lines)
    (folder / "claim.txt").write_text(report + "\n")
    return report
