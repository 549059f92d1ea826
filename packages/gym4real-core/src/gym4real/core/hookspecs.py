"""The hooks a ``gym4real.plugins`` entry point implements, and the version of this plugin API.

A plugin module marks its functions with :data:`gym4real.core.hookimpl`. Every hook takes no
argument and returns plain records (see :mod:`gym4real.core.specs`); the module must import nothing
heavier than ``gym4real.core`` and the standard library, so that ``import gym4real`` stays cheap.
It declares the plugin API it was written for as ``plugin_api = "MAJOR.MINOR"`` (docs/plugins.md).
"""

from __future__ import annotations

from collections.abc import Iterable

import pluggy

from gym4real.core.specs import BaselineSpec, BenchmarkSpec, DatasetSpec, EnvSpec, TrainingSpec

#: Version of the plugin API (these hooks and the records of :mod:`gym4real.core.specs`). A minor bump only
#: adds (a hook, a record field with a default, a flag); anything else is a major bump. A plugin written for
#: ``M.m`` loads on a core whose API is ``M.n`` with ``n >= m``.
PLUGIN_API_VERSION = "0.2"

PROJECT = "gym4real"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def gym4real_register_envs() -> Iterable[EnvSpec]:  # type: ignore[empty-body]
    """Return the environments this plugin provides."""


@hookspec
def gym4real_register_datasets() -> Iterable[DatasetSpec]:  # type: ignore[empty-body]
    """Return the data files this plugin's environments read."""


@hookspec
def gym4real_register_baselines() -> Iterable[BaselineSpec]:  # type: ignore[empty-body]
    """Return the named policies (rule-based baselines, experts) of this plugin's environments."""


@hookspec
def gym4real_register_benchmarks() -> Iterable[BenchmarkSpec | TrainingSpec]:  # type: ignore[empty-body]
    """Return the evaluation protocols and RL training presets of this plugin's environments."""
