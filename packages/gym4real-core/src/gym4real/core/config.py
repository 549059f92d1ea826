"""Validated environment configuration: one pydantic model per environment, presets as YAML.

Every env constructor takes ``config`` (a config object, a mapping or the path of a YAML file),
``preset`` (the name of a YAML file packaged beside the env) and keyword overrides, and builds its
config with :meth:`EnvConfig.build`: preset first, then ``config``, then the overrides, merged key by
key, then validated. An unknown key or a wrong type raises :class:`ConfigError` naming the field.
"""

from __future__ import annotations

from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar, Literal, Self

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from gym4real.core.errors import ConfigError

Fidelity = Literal["corrected", "upstream"]


def read_yaml(source: Path | resources.abc.Traversable, what: str) -> dict[str, Any]:
    """Read a YAML mapping with ``yaml.safe_load``; any problem is a :class:`ConfigError` naming the file."""
    try:
        data = yaml.safe_load(source.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"cannot read {what} `{source}`: {exc}") from exc
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"{what} `{source}` must hold a mapping of fields, not {type(data).__name__}")
    return data


def merge(base: Mapping[str, Any], update: Mapping[str, Any]) -> dict[str, Any]:
    """Return ``base`` updated by ``update``, nested mappings merged key by key."""
    out = dict(base)
    for key, value in update.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merge(out[key], value)
        else:
            out[key] = value
    return out


def describe_validation_error(err: ValidationError, model: str) -> str:
    """One line per pydantic error, each naming the field: unknown fields and wrong values alike."""
    lines = []
    for e in err.errors():
        where = ".".join(str(p) for p in e["loc"]) or "(root)"
        if e["type"] == "extra_forbidden":
            lines.append(f"unknown field `{where}`")
        else:
            lines.append(f"field `{where}`: {e['msg']} (got {e.get('input')!r})")
    return f"invalid {model}: " + "; ".join(lines)


class EnvConfig(BaseModel):
    """Base of every environment's configuration (frozen, unknown keys rejected).

    Subclasses set ``presets_package``, the package whose ``presets/<name>.yaml`` files are the
    named presets, and ``default_preset``.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)

    presets_package: ClassVar[str] = ""
    default_preset: ClassVar[str] = "default"

    fidelity: Fidelity = Field(
        "corrected",
        description='"corrected" fixes the reference defects listed in the env docs; "upstream" reproduces them.',
    )
    data_dir: str | None = Field(
        None, description="Folder holding the data files; searched before GYM4REAL_DATA_DIR and the cache."
    )

    @classmethod
    def presets(cls) -> list[str]:
        """Return the names of the packaged presets."""
        folder = resources.files(cls.presets_package) / "presets"
        return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))

    @classmethod
    def preset(cls, name: str) -> dict[str, Any]:
        """Return the raw fields of a packaged preset."""
        source = resources.files(cls.presets_package) / "presets" / f"{name}.yaml"
        if not source.is_file():
            raise ConfigError(f"unknown preset `{name}` for {cls.__name__}; expected one of {cls.presets()}")
        return read_yaml(source, "preset")

    @classmethod
    def build(
        cls,
        config: EnvConfig | Mapping[str, Any] | str | Path | None = None,
        preset: str | None = None,
        **overrides: Any,
    ) -> Self:
        """Build a validated config from a preset, a config and keyword overrides.

        Args:
            config: A config object, a mapping of fields, or the path of a YAML file.
            preset: Name of a packaged preset; the default preset when ``config`` is not a config object.
            **overrides: Fields that replace those of the preset and config (nested mappings merge).

        Raises:
            ConfigError: An unknown field, a wrong type or value, an unknown preset or an unreadable file.
        """
        if isinstance(config, cls) and preset is None and not overrides:
            return config
        data: dict[str, Any] = {}
        if preset is not None or not isinstance(config, EnvConfig):
            data = cls.preset(preset or cls.default_preset)
        if isinstance(config, EnvConfig):
            data = merge(data, config.model_dump(exclude_unset=True))
        elif isinstance(config, (str, Path)):
            data = merge(data, read_yaml(Path(config), "config file"))
        elif config is not None:
            if not isinstance(config, Mapping):
                msg = f"`config` must be a {cls.__name__}, a mapping or a YAML path, not {type(config).__name__}"
                raise ConfigError(msg)
            data = merge(data, config)
        data = merge(data, overrides)
        try:
            return cls.model_validate(data)
        except ValidationError as exc:
            raise ConfigError(describe_validation_error(exc, cls.__name__)) from None
