"""Training presets: YAML files beside each domain, registered as ``TrainingSpec`` records."""

from __future__ import annotations

from importlib import resources
from typing import Any

from gym4real.core.config import read_yaml
from gym4real.core.errors import ConfigError
from gym4real.core.registry import env_spec, registry

ALGOS = ("ppo", "dqn", "qlearning", "sarsa")


def load_preset(env_id: str, algo: str, preset: str) -> dict[str, Any]:
    """Return the hyperparameters of a registered training preset.

    Raises:
        ConfigError: No such preset; the message lists the registered ones.
    """
    env_spec(env_id)
    trainings = registry().trainings
    spec = trainings.get((env_id, algo, preset))
    if spec is None:
        known = sorted(f"{a}/{p}" for (e, a, p) in trainings if e == env_id)
        raise ConfigError(f"no training preset `{algo}/{preset}` for `{env_id}`; registered: {known}")
    package, _, path = spec.resource.partition(":")
    data = read_yaml(resources.files(package) / path, "training preset")
    if data.get("algo", algo) != algo:
        raise ConfigError(f"training preset `{spec.resource}` says algo `{data['algo']}`, registered as `{algo}`")
    return {**data, "algo": algo}
