"""The plugin host of Gym4ReaL: the registry of plugins, their records, configuration, datasets, errors.

Measurement (:mod:`gym4real.bench`), training (:mod:`gym4real.rl`), publishing (:mod:`gym4real.results`) and
the command (:mod:`gym4real.cli`) are layers above it; this package imports none of them.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from gym4real.core.errors import (
    ActionError,
    ConfigError,
    DataFileError,
    EnvUnavailableError,
    Gym4RealError,
    PluginLoadError,
    PolicyError,
)
from gym4real.core.hookspecs import PLUGIN_API_VERSION, hookimpl
from gym4real.core.info import EnvInfo, env_info
from gym4real.core.registry import list_envs, plugin_errors, register_envs
from gym4real.core.specs import FLAGS, BaselineSpec, BenchmarkSpec, DatasetSpec, EnvSpec, TrainingSpec


def make(env_id: str, **kwargs: Any) -> Any:
    """``gymnasium.make`` with Gym4ReaL's errors: the nearest id, or the ``pip install`` that provides it."""
    import gymnasium

    from gym4real.core.registry import env_spec

    env_spec(env_id)
    register_envs()
    return gymnasium.make(env_id, **kwargs)


if TYPE_CHECKING:
    from gym4real.core.config import EnvConfig, Fidelity

# Imported on first use, so that `import gym4real` (plugin discovery) stays cheap.
_LAZY = {
    "EnvConfig": "gym4real.core.config",
    "Fidelity": "gym4real.core.config",
}


def __getattr__(name: str) -> Any:
    if name == "__version__":
        from importlib.metadata import version

        return version("gym4real-core")
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module `gym4real.core` has no attribute `{name}`")


__all__ = [
    "FLAGS",
    "PLUGIN_API_VERSION",
    "ActionError",
    "BaselineSpec",
    "BenchmarkSpec",
    "ConfigError",
    "DataFileError",
    "DatasetSpec",
    "EnvConfig",
    "EnvInfo",
    "EnvSpec",
    "EnvUnavailableError",
    "Fidelity",
    "Gym4RealError",
    "PluginLoadError",
    "PolicyError",
    "TrainingSpec",
    "env_info",
    "hookimpl",
    "list_envs",
    "make",
    "plugin_errors",
    "register_envs",
]
