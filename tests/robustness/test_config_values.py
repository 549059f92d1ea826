"""Configs: every float finite, every size bounded, every bad value a ConfigError naming its field.

Issue 12, section 2. The float fields are found by walking each env config's model (nested sections,
optional floats, tuples of floats, lists of sections), so a field added later is covered too.
"""

from __future__ import annotations

import math
import re
import time
import types
import typing
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

import gym4real
from gym4real.core.config import EnvConfig
from gym4real.core.errors import ConfigError
from gym4real.dam.config import DamConfig
from gym4real.elevator.config import ElevatorConfig
from gym4real.microgrid.config import MicrogridConfig
from gym4real.robofeeder.config import PickingConfig, PlanningConfig
from gym4real.trading.config import TradingConfig
from gym4real.wds.config import WDSConfig

CONFIGS: tuple[type[EnvConfig], ...] = (
    DamConfig,
    ElevatorConfig,
    MicrogridConfig,
    PickingConfig,
    PlanningConfig,
    TradingConfig,
    WDSConfig,
)


def _args(annotation: Any) -> tuple[Any, ...]:
    """The members of a union (``float | None``), or the annotation itself."""
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return typing.get_args(annotation)
    return (annotation,)


def _float_fields(model: type[BaseModel], prefix: tuple[str, ...] = ()) -> list[tuple[tuple[str, ...], str]]:
    """``(path, how)`` of every float field below ``model``; ``how`` is "float", "tuple:<i>" or "list"."""
    found = []
    for name, info in model.model_fields.items():
        path = (*prefix, name)
        for arg in _args(info.annotation):
            origin = typing.get_origin(arg)
            if arg is float:
                found.append((path, "float"))
            elif origin is tuple:
                found += [(path, f"tuple:{i}") for i, a in enumerate(typing.get_args(arg)) if a is float]
            elif origin is list and isinstance(typing.get_args(arg)[0], type):
                item = typing.get_args(arg)[0]
                if issubclass(item, BaseModel):
                    found += [((*path, *sub), f"list:{how}") for sub, how in _float_fields(item)]
            elif isinstance(arg, type) and issubclass(arg, BaseModel):
                found += _float_fields(arg, path)
    return found


FLOAT_FIELDS = [(cfg, path, how) for cfg in CONFIGS for path, how in _float_fields(cfg)]


def _override(cfg: type[EnvConfig], path: tuple[str, ...], how: str, value: float) -> dict[str, Any]:
    """Keyword overrides that put ``value`` into the field at ``path`` of an otherwise valid config."""
    base = cfg.build().model_dump()
    if how.startswith("list:"):  # a list of sections: the value goes into its first item
        key, field = path[0], path[-1]
        items = [dict(item) for item in base[key]]
        items[0][field] = value
        return {key: items}
    if how.startswith("tuple:"):
        node = base
        for key in path:
            node = node[key]
        items = list(node)
        items[int(how.split(":")[1])] = value
        value = tuple(items)  # type: ignore[assignment]
    out: dict[str, Any] = {path[-1]: value}
    for key in reversed(path[:-1]):
        out = {key: out}
    return out


def test_the_walk_finds_the_fields_of_the_issue() -> None:
    names = {(cfg.__name__, ".".join(path)) for cfg, path, _ in FLOAT_FIELDS}
    expected = {
        ("ElevatorConfig", "reward_coeff"),
        ("DamConfig", "lake.surface"),
        ("DamConfig", "lake.init_level"),
        ("DamConfig", "flood_level"),
        ("DamConfig", "reward.daily_deficit_coeff"),
        ("MicrogridConfig", "battery.replacement_cost"),
        ("MicrogridConfig", "reward.clipping"),
        ("MicrogridConfig", "reward.trading"),
        ("TradingConfig", "capital"),
        ("TradingConfig", "fees"),
        ("WDSConfig", "reward.overflow_coeff"),
        ("WDSConfig", "pda.required_pressure"),
        ("WDSConfig", "pda.minimum_pressure"),
        ("WDSConfig", "default_rule.low"),
        ("PickingConfig", "controller.long_pause"),
        ("PickingConfig", "success_point"),
    }
    assert expected <= names
    assert len(FLOAT_FIELDS) > 80


non_finite = st.sampled_from([math.nan, -math.nan, math.inf, -math.inf])


@pytest.mark.parametrize(
    ("cfg", "path", "how"), FLOAT_FIELDS, ids=[f"{c.__name__}.{'.'.join(p)}[{h}]" for c, p, h in FLOAT_FIELDS]
)
@settings(max_examples=4, deadline=None)
@given(value=non_finite)
def test_every_float_field_of_every_env_config_rejects_nan_and_infinities(
    cfg: type[EnvConfig], path: tuple[str, ...], how: str, value: float
) -> None:
    overrides = _override(cfg, path, how, value)
    where = ".".join(path) if not how.startswith("list:") else f"{path[0]}.0.{path[-1]}"
    with pytest.raises(ConfigError, match=rf"field `{re.escape(where)}(\.\d)?`: Input should be a finite number"):
        cfg.build(**overrides)


# -- sizes: bounded by what the domain means, with the bound in the error ---------------------------

SIZES = [
    (ElevatorConfig, {"elevator": {"max_floor": 100_000}}, "elevator.max_floor", "200"),
    (ElevatorConfig, {"duration": 10**12}, "duration", "86400"),
    (ElevatorConfig, {"floors": {"lambda_max": 1e30}}, "floors.lambda_max", "100"),
    (ElevatorConfig, {"elevator": {"movement_speed": 1e-300}}, "elevator.movement_speed", "0.1"),
    (ElevatorConfig, {"elevator": {"floor_height": 1e308, "movement_speed": 3.0}}, "elevator.floor_height", "20"),
    (ElevatorConfig, {"elevator": {"max_capacity": 2**70}}, "elevator.max_capacity", "100"),
    (DamConfig, {"sim_horizon": 10**9}, "sim_horizon", "36500"),
    (TradingConfig, {"number_of_deltas": 10**9}, "number_of_deltas", "1440"),
    (TradingConfig, {"source": {"utc_offset_hours": 1e6}}, "source.utc_offset_hours", "14"),
    (MicrogridConfig, {"data": {"timestep": 1e300}}, "data.timestep", "86400"),
    (MicrogridConfig, {"data": {"temp_timestep": 1e300}}, "data.temp_timestep", "86400"),
    (PickingConfig, {"controller": {"long_pause": 1e9}}, "controller.long_pause", "1"),
    (PickingConfig, {"controller": {"short_pause": 1e9}}, "controller.short_pause", "1"),
    (PickingConfig, {"controller": {"delta_gripper": 1e-300}}, "controller.delta_gripper", "0.0001"),
    (PickingConfig, {"settle_steps": 10**12}, "settle_steps", "10000"),
    (PlanningConfig, {"post_pick_steps": 10**12}, "post_pick_steps", "10000"),
]


@pytest.mark.parametrize(("cfg", "overrides", "field", "bound"), SIZES, ids=[s[2] for s in SIZES])
def test_sizes_are_bounded_with_the_bound_in_the_error(
    cfg: type[EnvConfig], overrides: dict[str, Any], field: str, bound: str
) -> None:
    with pytest.raises(ConfigError, match=rf"field `{re.escape(field)}`: Input should be .* {re.escape(bound)} "):
        cfg.build(**overrides)


def test_every_packaged_preset_is_inside_the_bounds() -> None:
    for cfg in CONFIGS:
        for name in cfg.presets():
            cfg.build(preset=name)


# -- raw exceptions of the issue: a ConfigError naming the field, at construction ------------------

NAMED = [
    ("gym4real/elevator-v0", {"elevator": {"floor_height": math.inf}}, "elevator.floor_height"),
    ("gym4real/elevator-v0", {"elevator": {"movement_speed": math.inf}}, "elevator.movement_speed"),
    ("gym4real/elevator-v0", {"floors": {"lambda_max": math.inf}}, "floors.lambda_max"),
    ("gym4real/trading-v0", {"source": {"utc_offset_hours": math.nan}}, "source.utc_offset_hours"),
    ("gym4real/dam-v0", {"lake": {"init_level": math.inf}}, "lake.init_level"),
    ("gym4real/dam-v0", {"lake": {"init_level": 1e300}}, "lake.init_level"),
    ("gym4real/dam-v0", {"flood_level": math.nan}, "flood_level"),
    ("gym4real/microgrid-v0", {"data": {"timestep": math.inf}}, "data.timestep"),
]


@pytest.mark.parametrize(("env_id", "overrides", "field"), NAMED, ids=[f"{e}:{f}" for e, _, f in NAMED])
def test_bad_values_of_the_issue_are_config_errors_naming_the_field(
    env_id: str, overrides: dict[str, Any], field: str
) -> None:
    with pytest.raises(ConfigError, match=f"`{re.escape(field)}`"):
        gym4real.make(env_id, **overrides)


# -- YAML files ------------------------------------------------------------------------------------


def test_a_non_utf8_config_file_is_a_config_error_naming_the_file(tmp_path: Path) -> None:
    path = tmp_path / "latin1.yaml"
    path.write_bytes("reward_coeff: 5.0  # coefficient \xb0\n".encode("latin-1"))
    with pytest.raises(ConfigError, match=rf"`{re.escape(str(path))}` is not UTF-8 text"):
        ElevatorConfig.build(str(path))


def _laughs(levels: int, fan_out: int) -> str:
    lines = ["a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for k in range(1, levels):
        refs = ", ".join([f"*a{k - 1}"] * fan_out)
        lines.append(f"a{k}: &a{k} [{refs}]")
    lines.append(f"years: *a{levels - 1}")
    return "\n".join(lines) + "\n"


def test_a_billion_laughs_file_is_refused_before_it_is_expanded(tmp_path: Path) -> None:
    text = _laughs(9, 9)  # 9**9 (387 million) strings once expanded
    assert len(text) < 1024
    path = tmp_path / "laughs.yaml"
    path.write_text(text)
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=r"expands to more than [\d,]+ values through YAML aliases") as exc:
        DamConfig.build(str(path))
    assert time.perf_counter() - start < 5.0  # refused from the node graph: nothing was expanded
    assert str(path) in str(exc.value) and len(str(exc.value)) < 500


def test_aliases_that_stay_small_are_fine(tmp_path: Path) -> None:
    path = tmp_path / "anchors.yaml"
    path.write_text("reward: {overflow_coeff: &w 500.0, starving_coeff: *w}\n")
    reward = DamConfig.build(str(path)).reward
    assert reward.overflow_coeff == reward.starving_coeff == 500.0


def test_what_an_error_quotes_of_a_large_input_is_capped() -> None:
    huge = [[float(i)] for i in range(50_000)]  # a wrong value for `years`, under the alias limit
    with pytest.raises(ConfigError, match=r"field `years.0`.*and \d+ more") as exc:
        DamConfig.build(years=huge)
    assert len(str(exc.value)) < 2_000
    with pytest.raises(ConfigError, match=r"field `reward_coeff`") as exc:
        ElevatorConfig.build(reward_coeff="9" * 1_000_000)
    assert len(str(exc.value)) < 500


# -- presets are names ------------------------------------------------------------------------------


@pytest.mark.parametrize("preset", ["../rl/qlearning_paper", "../presets/test"])
def test_preset_takes_a_name_not_a_path(preset: str) -> None:
    with pytest.raises(ConfigError, match=r"unknown preset .*expected one of \['default', 'test'\]"):
        gym4real.make("gym4real/elevator-v0", preset=preset)


def test_an_absolute_path_as_preset_is_refused_and_the_file_form_works(tmp_path: Path) -> None:
    path = tmp_path / "mine.yaml"
    path.write_text("duration: 120\n")
    with pytest.raises(ConfigError, match=re.escape(f"pass a YAML file as `config='{path}'`")):
        ElevatorConfig.build(preset=str(path.with_suffix("")))
    assert ElevatorConfig.build(config=str(path)).duration == 120
