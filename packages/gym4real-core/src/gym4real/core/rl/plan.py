"""The plan of ``gym4real reproduce``: which training runs (env x algorithm x seed) a budget asks for.

Each run of a plan is independent of the others (its own seed and folder), so an executor may run them in
any order, one at a time or in parallel (:mod:`gym4real.core.rl.runner`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from gym4real.core.errors import ConfigError
from gym4real.core.registry import env_spec, registry
from gym4real.core.rl.presets import load_preset

#: Budget -> the preset that serves it when no preset declares it (``TrainingSpec.budget``).
BUDGETS = {"paper": "paper", "quick": "smoke"}
#: Seeds of the paper budget at least (the paper's, then 0, 1, ...): the training seed is the unit of
#: replication, and an interval over fewer seeds says little (the paper trained dam, wds and elevator on one).
DEFAULT_SEEDS = 5
#: Seeds of the quick budget (the first of the paper's).
QUICK_SEEDS = 2


def check_request(env_ids: Sequence[str], budget: str, n_seeds: int | None) -> None:
    """Refuse, before anything runs, what no environment of a request can run.

    Raises:
        EnvUnavailableError: An id that is not registered (a typo, a domain not installed), from
            :func:`~gym4real.core.registry.env_spec`: the nearest ids, or the ``pip install`` of the domain.
        ConfigError: An unknown budget, or fewer than one seed.
    """
    for env_id in env_ids:
        env_spec(env_id)
    _check_budget(budget)
    _check_seed_count(n_seeds)


def _check_budget(budget: str) -> None:
    if budget not in BUDGETS:
        raise ConfigError(f"budget `{budget}` is not one of {sorted(BUDGETS)}")


def _check_seed_count(n: int | None) -> None:
    if n is not None and n < 1:
        raise ConfigError(f"--seeds must be at least 1, not {n}")


def slug(env_id: str) -> str:
    """``gym4real/dam-v0`` -> ``dam-v0``."""
    return env_id.split("/", 1)[-1]


def presets(env_id: str, budget: str) -> dict[str, str]:
    """The training preset of each algorithm of ``env_id`` for ``budget``: one declared for it, else the budget's."""
    _check_budget(budget)
    found: dict[str, str] = {}
    for (env, algo, preset), spec in sorted(registry().trainings.items()):
        if env == env_id and spec.budget == budget:
            found[algo] = preset
    for env, algo, preset in sorted(registry().trainings):
        if env == env_id and preset == BUDGETS[budget]:
            found.setdefault(algo, preset)
    return found


def seeds(env_id: str, budget: str, n: int | None = None) -> list[int]:
    """The training seeds: the paper's (from the ``paper`` budget's presets), then 0, 1, 2, ...

    Args:
        env_id: A registered id.
        budget: ``paper`` or ``quick``.
        n: How many (default: as many as the paper used, at least :data:`DEFAULT_SEEDS`; for ``quick``
            the first :data:`QUICK_SEEDS` of the paper's, or of 0, 1, ... if it names none).
    """
    paper: list[int] = []
    for algo, preset in presets(env_id, "paper").items():
        for s in load_preset(env_id, algo, preset)["seeds"]:
            if s not in paper:
                paper.append(s)
    if n is None:
        n = min(len(paper) or QUICK_SEEDS, QUICK_SEEDS) if budget == "quick" else max(len(paper), DEFAULT_SEEDS)
    _check_seed_count(n)
    extra = (s for s in range(10**6) if s not in paper)
    return (paper + [next(extra) for _ in range(max(0, n - len(paper)))])[:n]


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


def plan(env_id: str, budget: str, n_seeds: int | None, out: Path) -> list[Item]:
    """The training runs of ``env_id`` for ``budget``, in ``out/<env>/<budget>/runs/<algo>/seed<S>``."""
    algos = presets(env_id, budget)
    if not algos:
        raise ConfigError(f"`{env_id}` registers no training preset for the `{budget}` budget")
    base = out / slug(env_id) / budget / "runs"
    run_seeds = seeds(env_id, budget, n_seeds)
    return [
        Item(env_id, algo, preset, s, base / algo / f"seed{s}") for algo, preset in algos.items() for s in run_seeds
    ]
