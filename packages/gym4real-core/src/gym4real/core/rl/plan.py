"""The plan of ``gym4real reproduce``: which training runs (env x algorithm x seed) a budget asks for.

Each run of a plan is independent of the others (its own seed and folder), so an executor may run them in
any order, one at a time or in parallel (:mod:`gym4real.core.rl.runner`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeAlias

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
#: The training seeds of a request (``--seeds`` of ``reproduce`` and ``evaluate``): a number ``N``, the first N
#: seeds of the plan (:func:`seeds`), or a list, exactly these seeds; None: the budget's default.
SeedRequest: TypeAlias = int | Sequence[int] | None
#: ``--seeds``, said once for every command that takes it.
SEEDS_HELP = (
    "N: the first N training seeds of the plan (the paper's, then 0, 1, ...); a,b,c: exactly these seeds "
    "(one seed S: `S,`)"
)


def parse_seeds(text: str) -> int | list[int]:
    """``--seeds``: ``N`` (a count) or ``a,b,c`` (these seeds; ``S,`` is the one seed S); see :data:`SeedRequest`.

    Raises:
        ConfigError: Text that is neither, with the two forms.
    """
    parts = [p.strip() for p in text.split(",")]
    try:
        values = [int(p) for p in parts if p]
    except ValueError:
        values = []
    if not values or any(v < 0 for v in values) or any(not p for p in parts[:-1]):
        raise ConfigError(
            f"`--seeds {text}` is neither a number of seeds (`--seeds 5`: the first five of the plan) nor "
            "comma-separated seeds (`--seeds 0,1,2`; one seed: `--seeds 7,`)"
        )
    return values[0] if len(parts) == 1 else values


def check_request(env_ids: Sequence[str], budget: str, n_seeds: SeedRequest) -> None:
    """Refuse, before anything runs, what no environment of a request can run.

    Raises:
        EnvUnavailableError: An id that is not registered (a typo, a domain not installed), from
            :func:`~gym4real.core.registry.env_spec`: the nearest ids, or the ``pip install`` of the domain.
        ConfigError: An unknown budget, fewer than one seed, or a seed list that repeats a seed.
    """
    for env_id in env_ids:
        env_spec(env_id)
    _check_budget(budget)
    _check_seed_count(n_seeds)


def _check_budget(budget: str) -> None:
    if budget not in BUDGETS:
        raise ConfigError(f"budget `{budget}` is not one of {sorted(BUDGETS)}")


def _check_seed_count(n: SeedRequest) -> None:
    if isinstance(n, int) and n < 1:
        raise ConfigError(f"--seeds must be at least 1, not {n}")
    if n is not None and not isinstance(n, int):
        listed = list(n)
        if not listed or len(set(listed)) != len(listed) or any(s < 0 for s in listed):
            raise ConfigError(
                f"--seeds {','.join(map(str, listed))}: name at least one seed, none twice, none negative"
            )


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


def seeds(env_id: str, budget: str, n: SeedRequest = None) -> list[int]:
    """The training seeds: the paper's (from the ``paper`` budget's presets), then 0, 1, 2, ...

    Args:
        env_id: A registered id.
        budget: ``paper`` or ``quick``.
        n: How many (default: as many as the paper used, at least :data:`DEFAULT_SEEDS`; for ``quick``
            the first :data:`QUICK_SEEDS` of the paper's, or of 0, 1, ... if it names none), or a list:
            exactly these seeds.
    """
    if n is not None and not isinstance(n, int):
        _check_seed_count(n)
        return list(n)
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


def seeds_flag(env_id: str, budget: str, run_seeds: Sequence[int]) -> str:
    """The ``--seeds`` value that asks for ``run_seeds`` again: their number if they are the plan's first, else them."""
    if list(run_seeds) == seeds(env_id, budget, len(run_seeds)):
        return str(len(run_seeds))
    return ",".join(map(str, run_seeds)) + ("," if len(run_seeds) == 1 else "")


def plan(env_id: str, budget: str, n_seeds: SeedRequest, out: Path) -> list[Item]:
    """The training runs of ``env_id`` for ``budget``, in ``out/<env>/<budget>/runs/<algo>/seed<S>``."""
    algos = presets(env_id, budget)
    if not algos:
        raise ConfigError(f"`{env_id}` registers no training preset for the `{budget}` budget")
    base = out / slug(env_id) / budget / "runs"
    run_seeds = seeds(env_id, budget, n_seeds)
    return [
        Item(env_id, algo, preset, s, base / algo / f"seed{s}") for algo, preset in algos.items() for s in run_seeds
    ]
