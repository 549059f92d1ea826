"""Discovery of the ``gym4real.plugins`` entry points, each loaded and called in isolation.

A plugin is registered whole or not at all. One that fails to import (any exception but
KeyboardInterrupt, ``SystemExit`` included), declares a ``plugin_api`` this core does not serve, has
a hook that raises or returns a bad or repeated record, names an env module that is missing, or
claims an entry-point name, env id or record that another distribution claims too (then neither is
registered) is reported once (logged on ``gym4real.plugins`` and returned by :func:`plugin_errors`)
and every other plugin still loads.
``GYM4REAL_STRICT_PLUGINS=1`` turns such failures into a :class:`PluginLoadError`;
``GYM4REAL_DISABLE_PLUGINS=wds,robofeeder`` skips plugins by name.
"""

from __future__ import annotations

import functools
import importlib
import itertools
import logging
import os
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field
from importlib import metadata as importlib_metadata
from typing import Any, NoReturn, cast

import pluggy

from gym4real.core import hookspecs
from gym4real.core.errors import ConfigError, EnvUnavailableError, PluginLoadError
from gym4real.core.hookspecs import PLUGIN_API_VERSION
from gym4real.core.specs import BaselineSpec, BenchmarkSpec, DatasetSpec, EnvSpec, TrainingSpec
from gym4real.core.suggest import did_you_mean

ENTRY_POINT_GROUP = "gym4real.plugins"

#: Domain key -> distribution, so that an id of a domain that is not installed gets a pip hint.
KNOWN_DOMAINS: dict[str, str] = {
    d: f"gym4real-{d}" for d in ("dam", "elevator", "microgrid", "robofeeder", "trading", "wds")
}

#: The canonical ids of the paper's environments.
CANONICAL_IDS: tuple[str, ...] = (
    "gym4real/dam-v0",
    "gym4real/elevator-v0",
    "gym4real/microgrid-v0",
    "gym4real/robofeeder-picking-v0",
    "gym4real/robofeeder-picking-v1",
    "gym4real/robofeeder-planning-v0",
    "gym4real/trading-v0",
    "gym4real/wds-v0",
)

#: Entry point of the vector-reward variants (``gym4real/dam-mo-v0``) of multi-objective envs.
MULTI_OBJECTIVE = "gym4real.wrappers.multi_objective:MultiObjective"
#: Entry point Gymnasium holds for an id whose plugin failed: making it raises why, and the fix.
UNAVAILABLE = "gym4real.core.registry:unavailable"

logger = logging.getLogger("gym4real.plugins")


@dataclass(frozen=True)
class PluginError:
    """A plugin that was not registered, and why.

    ``phase`` is ``"import"``, ``"compatibility"`` (its ``plugin_api`` is not served by this core),
    ``"hook validation"``, a hook name (the hook raised or returned a bad or repeated record) or
    ``"conflict"`` (its entry-point name, or a record's id, is claimed by another distribution too).
    """

    plugin: str
    distribution: str
    version: str
    phase: str
    error: str
    fix: str = ""

    def __str__(self) -> str:
        fix = self.fix or f"reinstall it with `pip install --force-reinstall {self.distribution}`"
        if not self.fix and "ModuleNotFoundError" in self.error:
            fix = f"install the missing dependency, or {fix}"
        return (
            f"plugin `{self.plugin}` ({self.distribution} {self.version}) failed in {self.phase}: {self.error}; {fix}"
        )


@dataclass
class Registry:
    """Everything the installed plugins registered, keyed for lookup."""

    envs: dict[str, EnvSpec] = field(default_factory=dict)
    datasets: dict[str, DatasetSpec] = field(default_factory=dict)
    baselines: dict[str, dict[str, BaselineSpec]] = field(default_factory=dict)
    benchmarks: dict[str, BenchmarkSpec] = field(default_factory=dict)
    trainings: dict[tuple[str, str, str], TrainingSpec] = field(default_factory=dict)
    owners: dict[str, str] = field(default_factory=dict)  # env id or record key -> plugin
    distributions: dict[str, tuple[str, str]] = field(default_factory=dict)  # plugin -> (dist, version)
    metadata: dict[str, importlib_metadata.Distribution] = field(default_factory=dict)  # plugin -> its installed dist
    errors: list[PluginError] = field(default_factory=list)
    rejected: dict[str, str] = field(default_factory=dict)  # env id of a plugin that was not registered -> plugin
    multi_objective: dict[str, str] = field(default_factory=dict)  # vector-reward id -> the env it wraps


Record = EnvSpec | DatasetSpec | BaselineSpec | BenchmarkSpec | TrainingSpec

#: The hooks, in the order they are called, with the records each may return.
HOOKS: tuple[tuple[str, tuple[type, ...]], ...] = (
    ("gym4real_register_envs", (EnvSpec,)),
    ("gym4real_register_datasets", (DatasetSpec,)),
    ("gym4real_register_baselines", (BaselineSpec,)),
    ("gym4real_register_benchmarks", (BenchmarkSpec, TrainingSpec)),
)


def _entry_points() -> Iterable[importlib_metadata.EntryPoint]:
    return importlib_metadata.entry_points(group=ENTRY_POINT_GROUP)


def _strict() -> bool:
    return os.environ.get("GYM4REAL_STRICT_PLUGINS", "") not in ("", "0", "false")


def _disabled() -> set[str]:
    return {n.strip() for n in os.environ.get("GYM4REAL_DISABLE_PLUGINS", "").split(",") if n.strip()}


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def _dist_of(ep: importlib_metadata.EntryPoint) -> tuple[str, str]:
    if ep.dist is None:
        return KNOWN_DOMAINS.get(ep.name, "?"), "?"
    return ep.dist.name, ep.dist.version


def _report(reg: Registry, err: PluginError, exc: BaseException | None = None) -> None:
    reg.errors.append(err)
    logger.warning("%s", err)
    if exc is not None:
        logger.debug("traceback of plugin `%s`", err.plugin, exc_info=exc)


def _record(reg: Registry, plugin: str, phase: str, exc: BaseException) -> None:
    dist, version = reg.distributions.get(plugin, (KNOWN_DOMAINS.get(plugin, "?"), "?"))
    _report(reg, PluginError(plugin, dist, version, phase, _describe(exc)), exc)


def _api_version(text: object) -> tuple[int, int] | None:
    parts = text.split(".") if isinstance(text, str) else []
    return (int(parts[0]), int(parts[1])) if len(parts) == 2 and all(p.isdigit() for p in parts) else None


def _incompatibility(module: object, dist: str) -> tuple[str, str] | None:
    """The error and fix when ``module.plugin_api`` is not served by this core, else None."""
    declared = getattr(module, "plugin_api", None)
    wanted = _api_version(declared)
    major, minor = _api_version(PLUGIN_API_VERSION) or (0, 0)
    if wanted is None:
        return (
            f"declares plugin_api = {declared!r}, expected a string `MAJOR.MINOR`",
            f"ask the maintainers of {dist} to declare the plugin API it was written for, "
            f'for example plugin_api = "{PLUGIN_API_VERSION}"',
        )
    if wanted[0] == major and wanted[1] <= minor:
        return None
    error = f"written for plugin API {declared}, but gym4real-core serves plugin API {PLUGIN_API_VERSION}"
    if wanted > (major, minor):
        return (
            error,
            f"upgrade gym4real-core to a release that serves plugin API {declared}: `pip install -U gym4real-core`",
        )
    return error, f"upgrade {dist} to a release written for plugin API {major}.x: `pip install -U {dist}`"


def _load_plugins(reg: Registry) -> pluggy.PluginManager:
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    disabled = _disabled()
    by_name: dict[str, dict[tuple[tuple[str, str], str], importlib_metadata.EntryPoint]] = {}
    for ep in _entry_points():
        if ep.name not in disabled:
            by_name.setdefault(ep.name, {}).setdefault((_dist_of(ep), ep.value), ep)
    for name in sorted(by_name):
        claimants = [(dist, ep) for (dist, _), ep in by_name[name].items()]
        reg.distributions[name] = claimants[0][0]
        if claimants[0][1].dist is not None:
            reg.metadata[name] = claimants[0][1].dist
        if len(claimants) > 1:
            _name_conflict(reg, name, claimants)
            continue
        # isolation: one broken plugin must not hide the others, nor exit the interpreter
        try:
            module = claimants[0][1].load()
        except KeyboardInterrupt:
            raise
        except BaseException as exc:
            _record(reg, name, "import", exc)
            continue
        dist, version = reg.distributions[name]
        if not hasattr(module, "plugin_api"):
            msg = "plugin `%s` (%s %s) declares no `plugin_api`; loaded as written for plugin API %s"
            logger.warning(msg, name, dist, version, PLUGIN_API_VERSION)
        elif problem := _incompatibility(module, dist):
            _report(reg, PluginError(name, dist, version, "compatibility", *problem))
            continue
        try:
            pm.register(module, name=name)
        except pluggy.PluginValidationError as exc:
            _record(reg, name, "hook validation", exc)
    while True:  # hooks that are not part of the API: report the plugin and drop it
        try:
            pm.check_pending()
            return pm
        except pluggy.PluginValidationError as exc:
            _record(reg, pm.get_name(exc.plugin) or "?", "hook validation", exc)
            pm.unregister(exc.plugin)


def _name_conflict(
    reg: Registry, name: str, claimants: list[tuple[tuple[str, str], importlib_metadata.EntryPoint]]
) -> None:
    """Report every distribution that provides the entry point ``name``; none of them is loaded."""
    for (dist, version), ep in claimants:
        others = [(d, o.value) for d, o in claimants if o is not ep]
        also = ", ".join(f"{d} {v} (`{value}`)" for (d, v), value in others)
        error = f"entry point `{name}` (`{ep.value}`) is also provided by {also}"
        fix = _keep_one([*(d for (d, _), _ in others), dist])
        _report(reg, PluginError(name, dist, version, "conflict", error, fix))


def _keep_one(dists: list[str]) -> str:
    """The fix of a conflict between ``dists``."""
    return "keep only one of them: " + " or ".join(f"`pip uninstall {d}`" for d in dists)


def _key(rec: Record) -> str:
    """The name a record claims: an env id, ``dataset:<name>``, ``baseline:<id>:<name>``, ..."""
    if isinstance(rec, EnvSpec):
        return rec.id
    if isinstance(rec, DatasetSpec):
        return "dataset:" + rec.name
    if isinstance(rec, BaselineSpec):
        return f"baseline:{rec.env_id}:{rec.name}"
    if isinstance(rec, BenchmarkSpec):
        return "benchmark:" + rec.env_id
    return f"training:{rec.env_id}:{rec.algo}:{rec.preset}"


def _find_module(name: str) -> list[str] | None:
    """The submodule search path of module ``name`` ([] for a plain module), or None if it cannot be found.

    Only parent packages already imported are looked into; nothing is executed.
    """
    if name in sys.modules:
        return list(getattr(sys.modules[name], "__path__", []))
    parent, _, _ = name.rpartition(".")
    path = _find_module(parent) if parent else None
    if parent and not path:
        return None
    for finder in sys.meta_path:
        find_spec = getattr(finder, "find_spec", None)
        spec = find_spec(name, path) if find_spec else None
        if spec is not None:
            return list(spec.submodule_search_locations or [])
    return None


def _check_entry_points(spec: EnvSpec) -> None:
    for what, target in (("entry point", spec.entry_point), ("vector entry point", spec.vector_entry_point)):
        module = (target or "").partition(":")[0]
        if module and _find_module(module) is None:
            raise ModuleNotFoundError(f"the {what} `{target}` of `{spec.id}` names module `{module}`, which is missing")


def _records(reg: Registry, plugin: str, hooks: dict[tuple[str, str], Any]) -> list[Record] | None:
    """Every record of one plugin, or None (and a reported error) if any of its hooks fails: all or nothing."""
    records: list[Record] = []
    keys: set[str] = set()
    for hook, kinds in HOOKS:
        impl = hooks.get((plugin, hook))
        try:
            for returned in (impl.function() or ()) if impl else ():
                if not isinstance(returned, kinds):
                    names = " or ".join(k.__name__ for k in kinds)
                    raise TypeError(f"{hook} returned {type(returned).__name__}, expected {names}")
                rec = cast(Record, returned)
                if isinstance(rec, EnvSpec):
                    reg.rejected[rec.id] = plugin  # until the plugin is registered
                    _check_entry_points(rec)
                if (key := _key(rec)) in keys:
                    raise ValueError(f"`{key}` is returned twice")
                keys.add(key)
                records.append(rec)
        except KeyboardInterrupt:
            raise
        except BaseException as exc:
            _record(reg, plugin, hook, exc)
            return None
    return records


def _add(reg: Registry, plugin: str, rec: Record) -> None:
    reg.owners[_key(rec)] = plugin
    if isinstance(rec, EnvSpec):
        reg.rejected.pop(rec.id, None)
        reg.envs[rec.id] = rec
    elif isinstance(rec, DatasetSpec):
        reg.datasets[rec.name] = rec
    elif isinstance(rec, BaselineSpec):
        reg.baselines.setdefault(rec.env_id, {})[rec.name] = rec
    elif isinstance(rec, BenchmarkSpec):
        reg.benchmarks[rec.env_id] = rec
    else:
        reg.trainings[(rec.env_id, rec.algo, rec.preset)] = rec


def _clashes(reg: Registry, records: dict[str, list[Record]]) -> set[str]:
    """Report each plugin that claims a key another plugin claims too (naming both); return their names."""
    claims: dict[str, list[str]] = {}
    for plugin, recs in records.items():
        for rec in recs:
            claims.setdefault(_key(rec), []).append(plugin)
    clashes: dict[str, dict[str, list[str]]] = {}
    for key, owners in claims.items():
        for plugin, other in itertools.permutations(owners, 2):
            clashes.setdefault(plugin, {}).setdefault(other, []).append(key)
    for plugin, others in sorted(clashes.items()):
        dist, version = reg.distributions[plugin]
        also = "; ".join(
            f"{', '.join(f'`{k}`' for k in keys)} also registered by plugin `{o}` ({' '.join(reg.distributions[o])})"
            for o, keys in sorted(others.items())
        )
        fix = _keep_one([*(reg.distributions[o][0] for o in others), dist])
        _report(reg, PluginError(plugin, dist, version, "conflict", also, fix))
    return set(clashes)


def _discover() -> Registry:
    """Load the plugins and register each one whose hooks all succeed and that claims nothing another claims."""
    reg = Registry()
    pm = _load_plugins(reg)
    hooks = {(impl.plugin_name, hook): impl for hook, _ in HOOKS for impl in getattr(pm.hook, hook).get_hookimpls()}
    records: dict[str, list[Record]] = {}
    for plugin in sorted(name for name, _ in pm.list_name_plugin()):
        if (recs := _records(reg, plugin, hooks)) is not None:
            records[plugin] = recs
    clashing = _clashes(reg, records)
    for plugin, recs in records.items():
        for rec in recs if plugin not in clashing else ():
            _add(reg, plugin, rec)
    _add_multi_objective(reg)
    return reg


def _add_multi_objective(reg: Registry) -> None:
    """Add the vector-reward variant (``gym4real/dam-mo-v0``) of each env flagged multi-objective, owned by its plugin.

    A variant has the env's presets and data, and the reward components as its vector reward (see
    :class:`gym4real.wrappers.MultiObjective`); an id a plugin registers itself is left to it.
    """
    for spec in [s for s in reg.envs.values() if "multi_objective" in s.flags]:
        name, _, version = spec.id.rpartition("-v")
        mo_id = f"{name}-mo-v{version}"
        if mo_id in reg.envs:
            continue
        reg.envs[mo_id] = EnvSpec(
            id=mo_id,
            entry_point=MULTI_OBJECTIVE,
            description=f"multi-objective {spec.id}: a vector reward, one entry per reward component",
            flags=spec.flags,
            presets=spec.presets,
            datasets=spec.datasets,
            kwargs={"env": spec.id, **spec.kwargs},
        )
        reg.owners[mo_id] = reg.owners[spec.id]
        reg.multi_objective[mo_id] = spec.id


@functools.cache
def _cached() -> Registry:
    return _discover()


def registry(*, strict: bool | None = None) -> Registry:
    """Return what the installed plugins registered (discovered once per process).

    Args:
        strict: Raise :class:`PluginLoadError` if any plugin failed; defaults to
            ``GYM4REAL_STRICT_PLUGINS``.
    """
    reg = _cached()
    if reg.errors and (_strict() if strict is None else strict):
        lines = "\n".join(f"  - {e}" for e in reg.errors)
        raise PluginLoadError(f"{len(reg.errors)} gym4real plugin(s) failed to load:\n{lines}")
    return reg


def reload() -> Registry:
    """Forget the discovered plugins and discover them again (for tests)."""
    _cached.cache_clear()
    return registry()


def plugin_errors() -> list[PluginError]:
    """Return the plugins that failed to load or register, one record each."""
    return list(_cached().errors)


def installed_distributions() -> list[tuple[str, str]]:
    """Return ``(name, version)`` of gym4real-core, then of every other installed gym4real distribution.

    A gym4real distribution is one named ``gym4real-*`` or one that provides a ``gym4real.plugins`` entry
    point (third-party plugins included); sorted by name after core.
    """
    found: dict[str, str] = {}
    for dist in importlib_metadata.distributions():
        name = dist.name or ""
        ours = name.lower().replace("_", "-").startswith("gym4real-")
        if ours or any(ep.group == ENTRY_POINT_GROUP for ep in dist.entry_points):
            found.setdefault(name, dist.version)  # the first on sys.path is the one imported
    return sorted(found.items(), key=lambda item: (item[0] != "gym4real-core", item[0]))


def list_envs(*, strict: bool | None = None, multi_objective: bool = True) -> list[str]:
    """Return the sorted ids of every installed environment (never raises for a plugin unless strict).

    Args:
        strict: Raise :class:`PluginLoadError` if a plugin failed; defaults to ``GYM4REAL_STRICT_PLUGINS``.
        multi_objective: Include the vector-reward variants (``gym4real/dam-mo-v0``; see
            ``registry().multi_objective``).
    """
    reg = registry(strict=strict)
    return sorted(i for i in reg.envs if multi_objective or i not in reg.multi_objective)


def load_object(path: str) -> Any:
    """Import ``"module:attr"`` (attr may be dotted): the entry points of baselines, protocols, loaders."""
    module, _, attr = path.partition(":")
    obj: Any = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def base_env(env_id: str) -> str:
    """The env a vector-reward variant wraps (``gym4real/dam-mo-v0`` -> ``gym4real/dam-v0``); any other id itself."""
    return registry().multi_objective.get(env_id, env_id)


def slug(env_id: str) -> str:
    """``gym4real/dam-v0`` -> ``dam-v0`` (the name of an id's files and folders)."""
    return env_id.split("/", 1)[-1]


def baseline_names(env_id: str) -> list[str]:
    """Return the names of the baselines registered for an environment (a vector-reward variant: its env's)."""
    return sorted(registry().baselines.get(base_env(env_id), {}))


def domain_of(env_id: str) -> str:
    """Return the domain key of an id (``gym4real/robofeeder-picking-v0`` -> ``robofeeder``)."""
    return env_id.split("/", 1)[-1].split("-", 1)[0]


def env_spec(env_id: str) -> EnvSpec:
    """Return the registered spec of an id, or raise an error that says how to get it.

    Raises:
        EnvUnavailableError: The id is unknown (the nearest ids are suggested), its domain is not
            installed (the ``pip install`` is given), or its plugin failed to load.
    """
    reg = registry()
    if env_id in reg.envs:
        return reg.envs[env_id]
    raise _unavailable_error(reg, env_id)


def unavailable(env_id: str, **_: Any) -> NoReturn:
    """The entry point of an id whose plugin failed (:data:`UNAVAILABLE`): raise why it cannot be made.

    Raises:
        EnvUnavailableError: The plugin's error, naming its distribution(s) and the fix.
    """
    reg = registry()
    if env_id in reg.envs:  # its plugin loads now (the registry was rediscovered)
        msg = f"`{env_id}` was unavailable when Gymnasium's registry was filled: call `gym4real.register_envs()`"
        raise EnvUnavailableError(msg)
    raise _unavailable_error(reg, env_id)


def _unavailable_error(reg: Registry, env_id: str) -> EnvUnavailableError:
    """The error of an id that is not registered: its plugin's failure, a missing domain, or the nearest ids."""
    domain = domain_of(env_id)
    failed = [e for e in reg.errors if e.plugin in (domain, reg.rejected.get(env_id))]
    if failed:
        return EnvUnavailableError(f"environment `{env_id}` is provided by {failed[0]}")
    if domain in _disabled() and domain not in reg.distributions:
        return EnvUnavailableError(
            f"environment `{env_id}` is provided by plugin `{domain}`, which GYM4REAL_DISABLE_PLUGINS disables: "
            "remove it from that variable"
        )
    if env_id in CANONICAL_IDS or (domain in KNOWN_DOMAINS and domain not in reg.distributions):
        from gym4real.core.install_hint import install_command

        dist = KNOWN_DOMAINS.get(domain, f"gym4real-{domain}")
        return EnvUnavailableError(
            f"environment `{env_id}` is provided by `{dist}`, which is not installed: {install_command(dist)}"
        )
    hint = did_you_mean(env_id, reg.envs)
    return EnvUnavailableError(f"unknown environment `{env_id}`.{hint} Installed: {sorted(reg.envs)}")


def _failed_ids(reg: Registry) -> list[str]:
    """The ids that cannot be made.

    Those a failed plugin returned, and the paper's ids of a domain that failed, is not installed or is disabled.
    """
    failed = {e.plugin for e in reg.errors}
    absent = {i for i in CANONICAL_IDS if domain_of(i) in failed or domain_of(i) not in reg.distributions}
    return sorted({*reg.rejected, *absent} - set(reg.envs))


def register_envs() -> list[str]:
    """Register every discovered environment with Gymnasium (string entry points, no heavy import).

    The id of a plugin that failed, and each of the paper's ids whose domain is not installed, is registered with
    :data:`UNAVAILABLE`, so that ``gymnasium.make`` raises the plugin's error or the ``pip install`` of the
    domain, not Gymnasium's ``NameNotFound``.

    Returns:
        The ids registered by this call (ids already registered with the same entry point are skipped).
    """
    import gymnasium

    done = []

    reg = registry()
    for spec in reg.envs.values():
        old = gymnasium.registry.get(spec.id)
        if old is None or old.entry_point != spec.entry_point or old.kwargs != dict(spec.kwargs):
            gymnasium.register(
                id=spec.id,
                entry_point=spec.entry_point,
                kwargs=dict(spec.kwargs),
                max_episode_steps=spec.max_episode_steps,
                vector_entry_point=spec.vector_entry_point,
                # Gymnasium's passive checker wants a float reward: vector-reward ids skip it, as MO-Gymnasium's do
                disable_env_checker=spec.id in reg.multi_objective,
            )
            done.append(spec.id)
    for env_id in _failed_ids(reg):
        old = gymnasium.registry.get(env_id)
        if old is None or old.entry_point != UNAVAILABLE:
            gymnasium.register(id=env_id, entry_point=UNAVAILABLE, kwargs={"env_id": env_id}, disable_env_checker=True)
    return done


#: How a non-causal baseline (``BaselineSpec.causal`` False) is named wherever baselines are listed.
MARK = "non-causal upper reference"


def non_causal(env_id: str) -> list[str]:
    """The non-causal baselines (upper references) registered for an environment, sorted."""
    specs = registry().baselines.get(base_env(env_id), {})
    return sorted(name for name, spec in specs.items() if not spec.causal)


def upper_reference(env_id: str, name: str) -> BaselineSpec:
    """The registered spec of a non-causal baseline of an environment (its kind of bound: ``BaselineSpec.bound``).

    Raises:
        ConfigError: ``name`` is not a non-causal baseline of the environment.
    """
    spec = registry().baselines.get(base_env(env_id), {}).get(name)
    if spec is None or spec.causal:
        raise ConfigError(
            f"`{name}` is not a non-causal upper reference of `{env_id}`; those registered: {non_causal(env_id)}"
        )
    return spec
