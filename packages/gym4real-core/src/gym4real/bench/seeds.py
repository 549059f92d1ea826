"""The training seeds of a measurement: the unit of replication, shared by ``reproduce`` and ``evaluate``.

A budget (``paper``, ``quick``) names a training preset per algorithm; the paper's seeds are those its
presets list, then 0, 1, 2, ... A request (``--seeds``) is a count of the first seeds or a list.
"""

from __future__ import annotations

from collections.abc import Sequence
from importlib import resources
from pathlib import Path
from typing import Annotated, TypeAlias

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from gym4real.core.config import read_yaml
from gym4real.core.errors import ConfigError
from gym4real.core.registry import env_spec, registry

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
    if len(parts) == 1 and values[0] < 1:
        raise ConfigError(
            f"`--seeds {text}` is a number of seeds, which must be at least 1; for the one seed {values[0]} write "
            f"`--seeds {values[0]},` (a trailing comma makes it a list)"
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
    check_seed_count(n_seeds)


def _check_budget(budget: str) -> None:
    if budget not in BUDGETS:
        raise ConfigError(f"budget `{budget}` is not one of {sorted(BUDGETS)}")


def check_seed_count(n: SeedRequest) -> None:
    """Refuse a count below 1, or a list that is empty, repeats a seed or holds a negative one.

    Raises:
        ConfigError: Naming the request and, for a count of 0, the one-seed form ``0,``.
    """
    if isinstance(n, int) and n < 1:
        one = f"; for the one seed {n} write `{n},` (`seeds=[{n}]`)" if n == 0 else ""
        raise ConfigError(f"seeds: a number of seeds must be at least 1, not {n}{one}")
    if n is not None and not isinstance(n, int):
        listed = list(n)
        if not listed or len(set(listed)) != len(listed) or any(s < 0 for s in listed):
            raise ConfigError(
                f"--seeds {','.join(map(str, listed))}: name at least one seed, none twice, none negative"
            )


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
        check_seed_count(n)
        return list(n)
    paper: list[int] = []
    for algo, preset in presets(env_id, "paper").items():
        for s in _preset_seeds(env_id, algo, preset):
            if s not in paper:
                paper.append(s)
    if n is None:
        n = min(len(paper) or QUICK_SEEDS, QUICK_SEEDS) if budget == "quick" else max(len(paper), DEFAULT_SEEDS)
    check_seed_count(n)
    extra = (s for s in range(10**6) if s not in paper)
    return (paper + [next(extra) for _ in range(max(0, n - len(paper)))])[:n]


def is_preset_file(preset: str) -> bool:
    """Whether ``preset`` names a YAML file rather than a registered preset."""
    return preset.endswith((".yaml", ".yml"))


def preset_source(env_id: str, algo: str, preset: str) -> Path | resources.abc.Traversable:
    """The YAML file of a training preset: a registered name (``paper``, ``smoke``) or a path.

    Raises:
        ConfigError: A name that ``env_id`` does not register for ``algo`` (the message lists those it does).
    """
    if is_preset_file(preset):
        return Path(preset)
    trainings = registry().trainings
    spec = trainings.get((env_id, algo, preset))
    if spec is None:
        known = sorted(f"{a}/{p}" for (e, a, p) in trainings if e == env_id)
        raise ConfigError(
            f"no training preset `{algo}/{preset}` for `{env_id}`; registered: {known}, or the path of a YAML file"
        )
    package, _, path = spec.resource.partition(":")
    return resources.files(package) / path


#: A training preset's ``seeds``: the type both readers of a preset check (this module and :mod:`gym4real.rl.presets`).
Seeds = list[Annotated[int, Field(ge=0)]]


class _Seeds(BaseModel):
    """The one field of a training preset that measurement reads (:mod:`gym4real.rl.presets` checks the rest)."""

    model_config = ConfigDict(extra="ignore")
    seeds: Seeds = []


def _preset_seeds(env_id: str, algo: str, preset: str) -> list[int]:
    source = preset_source(env_id, algo, preset)
    try:
        return _Seeds.model_validate(read_yaml(source, "training preset")).seeds
    except ValidationError as exc:
        raise ConfigError(f"training preset `{source}`: `seeds` must be a list of non-negative seeds ({exc})") from None


def seeds_flag(env_id: str, budget: str, run_seeds: Sequence[int]) -> str:
    """The ``--seeds`` value that asks for ``run_seeds`` again: their number if they are the plan's first, else them."""
    if list(run_seeds) == seeds(env_id, budget, len(run_seeds)):
        return str(len(run_seeds))
    return listed_seeds_flag(run_seeds)


def listed_seeds_flag(run_seeds: Sequence[int]) -> str:
    """The ``--seeds`` value that names exactly ``run_seeds`` (one seed S: ``S,``, which is not a count)."""
    return ",".join(map(str, run_seeds)) + ("," if len(run_seeds) == 1 else "")
