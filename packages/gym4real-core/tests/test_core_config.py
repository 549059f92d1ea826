from __future__ import annotations

import sys
from pathlib import Path

import pytest
from pydantic import ConfigDict, Field, ValidationError

from gym4real.core.config import EnvConfig, PresetRenamedWarning, describe_validation_error, merge
from gym4real.core.errors import ConfigError


@pytest.fixture
def demo_config(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> type[EnvConfig]:
    pkg = tmp_path / "gym4real_demo_cfg"
    (pkg / "presets").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "presets" / "default.yaml").write_text("steps: 10\nweights: {a: 1.0, b: 2.0}\n")
    (pkg / "presets" / "test.yaml").write_text("steps: 20\n")
    (pkg / "presets" / "bad.yaml").write_text("- not\n- a mapping\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop("gym4real_demo_cfg", None)

    class DemoConfig(EnvConfig):
        presets_package = "gym4real_demo_cfg"
        steps: int = Field(5, ge=1)
        weights: dict[str, float] = {}

    return DemoConfig


def test_default_preset_then_overrides(demo_config) -> None:
    cfg = demo_config.build()
    assert cfg.steps == 10 and cfg.weights == {"a": 1.0, "b": 2.0} and cfg.fidelity == "corrected"
    cfg = demo_config.build(preset="test", fidelity="upstream")
    assert cfg.steps == 20 and cfg.fidelity == "upstream"
    cfg = demo_config.build({"weights": {"b": 3.0}})
    assert cfg.weights == {"a": 1.0, "b": 3.0}
    assert demo_config.build(cfg) is cfg
    assert demo_config.presets() == ["bad", "default", "test"]


def test_yaml_file_config(demo_config, tmp_path) -> None:
    path = tmp_path / "mine.yaml"
    path.write_text("steps: 7\n")
    assert demo_config.build(str(path)).steps == 7


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"steps": "many"}, "field `steps`"),
        ({"steps": 0}, "field `steps`"),
        ({"stepz": 3}, "unknown field `stepz`"),
        ({"fidelity": "exact"}, "field `fidelity`"),
        ({"preset": "nope"}, "unknown preset `nope`"),
        ({"preset": "bad"}, "must hold a mapping"),
    ],
)
def test_errors_name_the_field(demo_config, kwargs, needle) -> None:
    preset = kwargs.pop("preset", None)
    with pytest.raises(ConfigError, match=needle):
        demo_config.build(preset=preset, **kwargs)


def test_config_is_frozen_and_json_serialisable(demo_config) -> None:
    cfg = demo_config.build()
    with pytest.raises(ValueError):
        cfg.steps = 3  # type: ignore[misc]
    assert demo_config.model_validate_json(cfg.model_dump_json()) == cfg


def test_merge_is_deep() -> None:
    assert merge({"a": {"x": 1, "y": 2}, "b": 1}, {"a": {"y": 3}}) == {"a": {"x": 1, "y": 3}, "b": 1}


def test_a_mistyped_field_is_matched_to_the_nearest_name(demo_config) -> None:
    with pytest.raises(ConfigError, match=r"unknown field `stepz` \(did you mean `steps`\?\)"):
        demo_config.build(stepz=3)
    with pytest.raises(ConfigError) as far:
        demo_config.build(horizon=3)
    assert "did you mean" not in str(far.value)  # nothing near: no guess


def test_a_mistyped_nested_field_is_matched_within_its_section() -> None:
    from pydantic import BaseModel

    class Reward(BaseModel):
        model_config = ConfigDict(extra="forbid")
        trading: float = 1.0
        degradation: float = 1.0

    class Demo(BaseModel):
        model_config = ConfigDict(extra="forbid")
        reward: Reward = Reward()

    with pytest.raises(ValidationError) as err:
        Demo.model_validate({"reward": {"tradin": 2.0}})
    message = describe_validation_error(err.value, "Demo", Demo)
    assert message == "invalid Demo: unknown field `reward.tradin` (did you mean `reward.trading`?)"


def test_a_renamed_preset_still_works_for_a_release_and_names_its_new_name(demo_config) -> None:
    class Renamed(demo_config):  # type: ignore[misc, valid-type]
        preset_aliases = {"paper_test": "test"}

    with pytest.warns(PresetRenamedWarning, match="preset `paper_test` of Renamed is now called `test`"):
        assert Renamed.build(preset="paper_test") == Renamed.build(preset="test")
    with pytest.raises(ConfigError, match="unknown preset `paper_tset`"):
        Renamed.build(preset="paper_tset")
