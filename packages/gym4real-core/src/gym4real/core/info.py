"""``env_info``: what an installed environment is, where it comes from and what it registers.

``gym4real info`` adds what an instance shows (spaces, how an episode ends) and the evaluation protocol
(:mod:`gym4real.cli.envs`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from gym4real.core.registry import domain_of, env_spec, registry
from gym4real.core.specs import FLAGS


@dataclass(frozen=True)
class EnvInfo:
    """The record ``gym4real.env_info(id)`` returns.

    ``flags`` maps each of the paper's Table-1 characteristics and paradigms to whether the env has it.
    ``extra`` holds what the env's plugin reports at run time (for example the simulation engine).
    ``non_causal`` names the baselines that are non-causal upper references (``hindsight``: handed the
    episode's exogenous data; :mod:`gym4real.bench.upper_reference`), listed among ``baselines`` too.
    """

    id: str
    distribution: str
    version: str
    description: str
    flags: dict[str, bool]
    presets: tuple[str, ...]
    datasets: tuple[str, ...]
    baselines: tuple[str, ...]
    trainings: tuple[str, ...]
    extra: dict[str, Any]
    non_causal: tuple[str, ...] = ()


def env_info(env_id: str) -> EnvInfo:
    """Return the record of an installed environment (raises a helpful error for an unknown id)."""
    from gym4real.core.registry import baseline_names, load_object, non_causal

    spec = env_spec(env_id)
    reg = registry()
    dist, version = reg.distributions.get(domain_of(env_id), ("?", "?"))
    extra = dict(load_object(spec.info_provider)()) if spec.info_provider else {}
    return EnvInfo(
        id=spec.id,
        distribution=dist,
        version=version,
        description=spec.description,
        flags={f: f in spec.flags for f in FLAGS},
        presets=spec.presets,
        datasets=spec.datasets,
        baselines=tuple(baseline_names(env_id)),
        trainings=tuple(sorted(f"{a}/{p}" for (e, a, p) in reg.trainings if e == env_id)),
        extra=extra,
        non_causal=tuple(non_causal(env_id)),
    )
