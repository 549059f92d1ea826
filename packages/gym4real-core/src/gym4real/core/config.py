"""Validated environment configuration: one pydantic model per environment, presets as YAML.

Every env constructor takes ``config`` (a config object, a mapping or the path of a YAML file),
``preset`` (the name of a YAML file packaged beside the env) and keyword overrides, and builds its
config with :meth:`EnvConfig.build`: preset first, then ``config``, then the overrides, merged key by
key, then validated. An unknown key or a wrong type raises :class:`ConfigError` naming the field.
"""

from __future__ import annotations

import reprlib
import warnings
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar, Literal, Self

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from gym4real.core.errors import ConfigError, Gym4RealError
from gym4real.core.suggest import nearest

Fidelity = Literal["corrected", "upstream"]


class PresetRenamedWarning(FutureWarning):
    """A preset was asked for by its former name (kept for one release)."""


#: Most values a YAML file may hold once its aliases are expanded (a config has tens; "billion laughs" has 10**9).
MAX_YAML_VALUES = 100_000
#: Most characters of an input value quoted in an error message.
MAX_QUOTED = 80
#: A path in a fix is quoted whole up to this length (Linux's PATH_MAX), so that the fix can be pasted.
MAX_PATH_QUOTED = 4096
#: Most validation errors listed in one message.
MAX_LISTED = 10


def read_yaml(
    source: Path | resources.abc.Traversable, what: str, error: type[Gym4RealError] = ConfigError
) -> dict[str, Any]:
    """Read a YAML mapping with PyYAML's safe loader; any problem is an ``error`` naming the file.

    Tags are refused (safe loader), and so is a document whose aliases expand to more than
    :data:`MAX_YAML_VALUES` values, before anything is built from it.
    """
    try:
        loader = yaml.SafeLoader(source.read_text(encoding="utf-8"))
        try:
            node = loader.get_single_node()
            if node is not None:
                _check_expansion(node, f"{what} `{source}`", error)
            data = None if node is None else loader.construct_document(node)
        finally:
            loader.dispose()
    except UnicodeDecodeError as exc:
        msg = f"{what} `{source}` is not UTF-8 text ({exc.reason} at byte {exc.start}); save it as UTF-8"
        raise error(msg) from None
    except RecursionError:
        raise error(f"{what} `{source}` is nested too deeply to be a configuration; flatten it") from None
    except (OSError, yaml.YAMLError) as exc:
        raise error(f"cannot read {what} `{source}`: {exc}") from exc
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise error(f"{what} `{source}` must hold a mapping of fields, not {type(data).__name__}")
    return data


def _check_expansion(root: yaml.Node, what: str, error: type[Gym4RealError]) -> None:
    """Refuse a YAML node graph whose aliases expand to more than :data:`MAX_YAML_VALUES` values (or a cycle)."""
    sizes: dict[int, int] = {}
    pending: set[int] = set()

    def size(node: yaml.Node) -> int:
        key = id(node)
        if key in sizes:
            return sizes[key]
        if key in pending:
            raise error(f"{what} holds a recursive alias (an anchor used inside itself); write the values out")
        pending.add(key)
        total = 1
        if isinstance(node, yaml.SequenceNode):
            total += sum(size(child) for child in node.value)
        elif isinstance(node, yaml.MappingNode):
            total += sum(size(k) + size(v) for k, v in node.value)
        if total > MAX_YAML_VALUES:
            msg = (
                f"{what} expands to more than {MAX_YAML_VALUES:,} values through YAML aliases (`&anchor` / "
                "`*alias`); write the values out, or use fewer aliases"
            )
            raise error(msg)
        pending.discard(key)
        sizes[key] = total
        return total

    size(root)


def merge(base: Mapping[str, Any], update: Mapping[str, Any]) -> dict[str, Any]:
    """Return ``base`` updated by ``update``, nested mappings merged key by key."""
    out = dict(base)
    for key, value in update.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merge(out[key], value)
        else:
            out[key] = value
    return out


def _quoter() -> reprlib.Repr:
    r = reprlib.Repr()
    r.maxlevel, r.maxstring, r.maxother, r.maxlong = 3, MAX_QUOTED, MAX_QUOTED, MAX_QUOTED
    return r


_QUOTER = _quoter()


def quote(value: Any, limit: int = MAX_QUOTED) -> str:
    """``repr`` of a value for an error message, at most ``limit`` characters (never the whole of a huge input)."""
    text = _QUOTER.repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def nearest_field(schema: type[BaseModel], loc: tuple[str | int, ...]) -> str:
    """`` (did you mean `reward_coeff`?)`` for an unknown field at ``loc`` of ``schema``, or ``""`` if none is near."""
    model: Any = schema
    for part in loc[:-1]:  # walk down nested models (``reward.weight``)
        field = model.model_fields.get(part) if isinstance(part, str) else None
        model = field.annotation if field is not None else None
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            return ""
    near = nearest(str(loc[-1]), model.model_fields, n=1, cutoff=0.6)
    return f" (did you mean `{'.'.join([*map(str, loc[:-1]), near[0]])}`?)" if near else ""


def describe_validation_error(err: ValidationError, model: str, schema: type[BaseModel] | None = None) -> str:
    """One line per pydantic error, each naming the field: unknown fields and wrong values alike.

    What the error quotes of the input is capped (:func:`quote`), and so is the number of lines listed,
    so that a huge input cannot make a huge message. Given the ``schema`` that was validated, an unknown
    field is matched to the nearest field name.
    """
    errors = err.errors(include_url=False)
    lines = []
    for e in errors[:MAX_LISTED]:
        where = ".".join(str(p) for p in e["loc"]) or "(root)"
        where = where if len(where) <= MAX_QUOTED else where[: MAX_QUOTED - 3] + "..."
        if e["type"] == "extra_forbidden":
            lines.append(f"unknown field `{where}`" + (nearest_field(schema, e["loc"]) if schema else ""))
        elif e["type"] == "value_error":  # a validator's own message, which names its fields and values
            message = e["msg"].removeprefix("Value error, ")
            lines.append(message if not e["loc"] else f"`{where}`: {message}")
        else:
            lines.append(f"field `{where}`: {e['msg']} (got {quote(e.get('input'))})")
    if len(errors) > MAX_LISTED:
        lines.append(f"and {len(errors) - MAX_LISTED} more")
    return f"invalid {model}: " + "; ".join(lines)


class ConfigSection(BaseModel):
    """Base of every nested section of an environment's configuration.

    Frozen, unknown keys rejected, and every float finite: NaN and infinities are refused unless a field
    says otherwise (``Field(allow_inf_nan=True)``).
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class EnvConfig(BaseModel):
    """Base of every environment's configuration (frozen, unknown keys rejected).

    Subclasses set ``presets_package``, the package whose ``presets/<name>.yaml`` files are the
    named presets (``presets_folder`` names another folder of it), and ``default_preset``. Preset
    names follow one scheme: the split names ``train``, ``validation`` and ``test`` where the env has
    splits, ``default`` for the default. ``preset_aliases`` maps a former name to its new one: it is
    accepted for one release with a :class:`PresetRenamedWarning`. Every float is finite, as in
    :class:`ConfigSection`.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)

    presets_package: ClassVar[str] = ""
    presets_folder: ClassVar[str] = "presets"
    default_preset: ClassVar[str] = "default"
    preset_aliases: ClassVar[dict[str, str]] = {}

    fidelity: Fidelity = Field(
        "corrected",
        description='"corrected" fixes the reference defects listed in the env docs; "upstream" reproduces them.',
    )
    data_dir: str | None = Field(
        None, description="Folder holding the data files; searched before GYM4REAL_DATA_DIR and the cache."
    )

    @classmethod
    def _presets_dir(cls) -> resources.abc.Traversable:
        folder = resources.files(cls.presets_package)
        for part in cls.presets_folder.split("/"):
            folder = folder / part
        return folder

    @classmethod
    def presets(cls) -> list[str]:
        """Return the names of the packaged presets."""
        return sorted(p.name[:-5] for p in cls._presets_dir().iterdir() if p.name.endswith(".yaml"))

    @classmethod
    def preset(cls, name: str) -> dict[str, Any]:
        """Return the raw fields of a packaged preset (a name, never a path: a file is passed as ``config``).

        A former name (``preset_aliases``) warns and gives its new one's fields.
        """
        if isinstance(name, str) and name in cls.preset_aliases:
            new = cls.preset_aliases[name]
            warnings.warn(
                f"preset `{name}` of {cls.__name__} is now called `{new}`; the old name goes in the next release",
                PresetRenamedWarning,
                stacklevel=3,
            )
            name = new
        if not isinstance(name, str) or name not in cls.presets():
            shown = f"`{name}`" if isinstance(name, str) and len(name) <= MAX_QUOTED else quote(name)
            msg = f"unknown preset {shown} for {cls.__name__}; expected one of {cls.presets()}"
            text = str(name) if isinstance(name, (str, Path)) else ""
            if "/" in text or "\\" in text or text.endswith((".yaml", ".yml")):
                file = text if text.endswith((".yaml", ".yml")) else f"{text}.yaml"
                shown_file = repr(file) if len(file) <= MAX_PATH_QUOTED else "PATH.yaml"
                msg += f"; a preset is a name: pass a YAML file as `config={shown_file}`"
            raise ConfigError(msg)
        return read_yaml(cls._presets_dir() / f"{name}.yaml", "preset")

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
            raise ConfigError(describe_validation_error(exc, cls.__name__, cls)) from None
