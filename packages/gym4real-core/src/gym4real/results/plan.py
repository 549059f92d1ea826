"""The plan of ``gym4real reproduce``: which training runs (env x algorithm x seed) a budget asks for.

Each run of a plan is independent of the others (its own seed and folder), so an executor may run them in
any order, one at a time or in parallel (:mod:`gym4real.results.runner`). Budgets and seeds:
:mod:`gym4real.bench.seeds`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from gym4real.bench.seeds import SeedRequest, presets, seeds
from gym4real.core.errors import ConfigError
from gym4real.core.registry import slug


@dataclass(frozen=True)
class Item:
    """One training run of the plan."""

    env_id: str
    algo: str
    preset: str
    seed: int
    folder: Path
    #: A folder with a damaged file is moved aside and the run trained again (else the run is refused).
    retrain_damaged: bool = False
    #: The trainer (``sb3``, or ``jax`` for the JAX PPO trainer).
    trainer: str = "sb3"


def plan(env_id: str, budget: str, n_seeds: SeedRequest, out: Path, trainer: str = "sb3") -> list[Item]:
    """The training runs of ``env_id`` for ``budget``, in ``out/<env>/<budget>/runs/<agent>/seed<S>``.

    ``<agent>`` is the algorithm (``ppo``), or ``ppo-jax`` with ``trainer="jax"``, whose plan is the budget's PPO
    runs alone (trained by the JAX trainer).

    Raises:
        ConfigError: No preset for the budget (no PPO preset, with the JAX trainer).
    """
    from gym4real.rl.train import label

    algos = presets(env_id, budget)
    if trainer != "sb3":
        algos = {a: p for a, p in algos.items() if a == "ppo"}
    if not algos:
        what = "PPO preset" if trainer != "sb3" else "training preset"
        raise ConfigError(f"`{env_id}` registers no {what} for the `{budget}` budget")
    base = out / slug(env_id) / budget / "runs"
    run_seeds = seeds(env_id, budget, n_seeds)
    return [
        Item(env_id, algo, preset, s, base / label(algo, trainer) / f"seed{s}", trainer=trainer)
        for algo, preset in algos.items()
        for s in run_seeds
    ]
