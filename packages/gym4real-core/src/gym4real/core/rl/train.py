"""``gym4real train``: one entry point for every algorithm and registered preset."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

from gym4real.core.rl.presets import is_preset_file, load_preset


@dataclass(frozen=True)
class TrainingRun:
    """Where a training run wrote its results."""

    env_id: str
    algo: str
    preset: str
    model_path: Path
    curve_csv: Path
    wall_time_s: float

    @property
    def policy(self) -> str:
        """The bench policy string of the trained model (``ppo:DIR/model.zip``)."""
        return f"{self.algo}:{self.model_path}"


def default_out(env_id: str, algo: str, preset: str, seed: int) -> Path:
    """``runs/<env>/<algo>-<preset>-seed<S>``."""
    name = Path(preset).stem if is_preset_file(preset) else preset
    return Path("runs") / env_id.replace("/", "_") / f"{algo}-{name}-seed{seed}"


def train(
    env_id: str, algo: str, preset: str = "paper", seed: int = 0, out: str | Path | None = None, progress: bool = False
) -> TrainingRun:
    """Train an agent with a registered preset and write the model and the learning curve.

    Args:
        env_id: A registered id.
        algo: ``ppo``, ``dqn`` (Stable-Baselines3), ``qlearning`` or ``sarsa`` (tabular).
        preset: Training preset name (``paper``, ``smoke``) or the path of a YAML preset file.
        seed: Seed of the run.
        out: Output folder (default ``runs/<env>/<algo>-<preset>-seed<S>``).
        progress: Show a progress bar.
    """
    hp = load_preset(env_id, algo, preset)
    folder = Path(out) if out else default_out(env_id, algo, preset, seed)
    folder.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    if algo in ("qlearning", "sarsa"):
        from gym4real.core.rl.tabular import train_tabular

        model = train_tabular(env_id, hp, seed, folder, progress)
    else:
        from gym4real.core.rl.sb3 import train_sb3

        model = train_sb3(env_id, hp, seed, folder, progress)
    run = TrainingRun(env_id, algo, preset, model, folder / "curve.csv", time.perf_counter() - start)
    (folder / "run.json").write_text(
        json.dumps(
            {
                "env_id": env_id,
                "algo": algo,
                "preset": preset,
                "seed": seed,
                "hyperparameters": hp,
                "wall_time_s": run.wall_time_s,
            },
            indent=1,
        )
    )
    return run
