"""One preset naming scheme for every env: the split names train, validation, test, and default."""

from __future__ import annotations

from importlib import resources

import pytest
import yaml

import gym4real
from gym4real.core.registry import registry

IDS = gym4real.list_envs(multi_objective=False)


@pytest.mark.parametrize("env_id", IDS)
def test_every_env_has_a_default_and_a_test_preset(env_id: str) -> None:
    presets = registry().envs[env_id].presets
    assert presets[0] == "default", presets  # the first preset is the one make() uses
    assert "test" in presets, presets  # preset="test" works on every id


def _training_presets() -> list[tuple[str, str, dict]]:
    out = []
    for (env_id, algo, preset), spec in sorted(registry().trainings.items()):
        package, _, path = spec.resource.partition(":")
        out.append((env_id, f"{algo}/{preset}", yaml.safe_load((resources.files(package) / path).read_text())))
    return out


@pytest.mark.parametrize(("env_id", "name", "data"), _training_presets(), ids=lambda v: v if isinstance(v, str) else "")
def test_training_presets_use_the_current_preset_names(env_id: str, name: str, data: dict) -> None:
    presets = registry().envs[env_id].presets
    for key in ("env_kwargs", "eval_env_kwargs"):
        preset = (data.get(key) or {}).get("preset", "default")
        assert preset in presets, f"{name} of {env_id}: {key} preset `{preset}` is not one of {presets}"


@pytest.mark.parametrize("env_id", sorted(registry().benchmarks))
def test_benchmark_protocols_use_the_current_preset_names(env_id: str) -> None:
    preset = registry().benchmarks[env_id].env_kwargs.get("preset", "default")
    assert preset in registry().envs[env_id].presets
