"""Discovery of the ``gym4real.plugins`` entry points, each loaded and called in isolation.

A plugin that fails to import, or whose hook raises or returns bad records, is reported once (logged
on ``gym4real.plugins`` and returned by :func:`plugin_errors`) and every other plugin still loads.
``GYM4REAL_STRICT_PLUGINS=1`` turns such failures into a :class:`PluginLoadError`;
``GYM4REAL_DISABLE_PLUGINS=wds,robofeeder`` skips plugins by name.
"""

from __future__ import annotations

import difflib
import functools
import logging
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import importlib_metadata
import pluggy

from gym4real.core import hookspecs
from gym4real.core.errors import EnvUnavailableError, PluginLoadError
from gym4real.core.specs import BaselineSpec, BenchmarkSpec, DatasetSpec, EnvSpec, TrainingSpec

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

logger = logging.getLogger("gym4real.plugins")


@dataclass(frozen=True)
class PluginError:
    """A plugin that failed to load (``phase="import"``) or to register (``phase=<hook name>``)."""

    plugin: str
    distribution: str
    version: str
    phase: str
    error: str

    def __str__(self) -> str:
        fix = f"reinstall it with `pip install --force-reinstall {self.distribution}`"
        if "ModuleNotFoundError" in self.error:
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
    owners: dict[str, str] = field(default_factory=dict)  # env id or dataset name -> plugin
    distributions: dict[str, tuple[str, str]] = field(default_factory=dict)  # plugin -> (dist, version)
    errors: list[PluginError] = field(default_factory=list)


def _entry_points() -> Iterable[importlib_metadata.EntryPoint]:
    return importlib_metadata.entry_points(group=ENTRY_POINT_GROUP)


def _strict() -> bool:
    return os.environ.get("GYM4REAL_STRICT_PLUGINS", "") not in ("", "0", "false")


def _disabled() -> set[str]:
    return {n.strip() for n in os.environ.get("GYM4REAL_DISABLE_PLUGINS", "").split(",") if n.strip()}


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def _load_plugins(reg: Registry) -> pluggy.PluginManager:
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    disabled = _disabled()
    for ep in sorted(_entry_points(), key=lambda e: e.name):
        if ep.name in disabled or ep.name in reg.distributions:
            continue
        dist = ep.dist.name if ep.dist else KNOWN_DOMAINS.get(ep.name, "?")
        version = ep.dist.version if ep.dist else "?"
        reg.distributions[ep.name] = (dist, version)
        try:
            pm.register(ep.load(), name=ep.name)
        except Exception as exc:  # isolation: one broken plugin must not hide the others
            _record(reg, ep.name, "import", exc)
    try:
        pm.check_pending()
    except pluggy.PluginValidationError as exc:
        _record(reg, pm.get_name(exc.plugin) or "?", "hook validation", exc)
    return pm


def _record(reg: Registry, plugin: str, phase: str, exc: BaseException) -> None:
    dist, version = reg.distributions.get(plugin, (KNOWN_DOMAINS.get(plugin, "?"), "?"))
    err = PluginError(plugin, dist, version, phase, _describe(exc))
    reg.errors.append(err)
    logger.warning("%s", err)
    logger.debug("traceback of plugin `%s`", plugin, exc_info=exc)


def _collect(
    reg: Registry,
    pm: pluggy.PluginManager,
    hook: str,
    kinds: tuple[type, ...],
    add: Callable[[Registry, str, Any], None],
) -> None:
    for impl in getattr(pm.hook, hook).get_hookimpls():
        try:
            records = list(impl.function() or ())
            for rec in records:
                if not isinstance(rec, kinds):
                    names = " or ".join(k.__name__ for k in kinds)
                    raise TypeError(f"{hook} returned {type(rec).__name__}, expected {names}")
            for rec in records:
                add(reg, impl.plugin_name, rec)
        except Exception as exc:
            _record(reg, impl.plugin_name, hook, exc)


def _claim(reg: Registry, key: str, plugin: str) -> None:
    other = reg.owners.setdefault(key, plugin)
    if other != plugin:
        raise ValueError(f"`{key}` is registered by both plugin `{other}` and plugin `{plugin}`")


def _add_env(reg: Registry, plugin: str, spec: EnvSpec) -> None:
    _claim(reg, spec.id, plugin)
    reg.envs[spec.id] = spec


def _add_dataset(reg: Registry, plugin: str, spec: DatasetSpec) -> None:
    _claim(reg, "dataset:" + spec.name, plugin)
    reg.datasets[spec.name] = spec


def _add_baseline(reg: Registry, plugin: str, spec: BaselineSpec) -> None:
    _claim(reg, f"baseline:{spec.env_id}:{spec.name}", plugin)
    reg.baselines.setdefault(spec.env_id, {})[spec.name] = spec


def _add_benchmark(reg: Registry, plugin: str, spec: BenchmarkSpec | TrainingSpec) -> None:
    if isinstance(spec, BenchmarkSpec):
        _claim(reg, "benchmark:" + spec.env_id, plugin)
        reg.benchmarks[spec.env_id] = spec
    else:
        _claim(reg, f"training:{spec.env_id}:{spec.algo}:{spec.preset}", plugin)
        reg.trainings[(spec.env_id, spec.algo, spec.preset)] = spec


def _discover() -> Registry:
    reg = Registry()
    pm = _load_plugins(reg)
    _collect(reg, pm, "gym4real_register_envs", (EnvSpec,), _add_env)
    _collect(reg, pm, "gym4real_register_datasets", (DatasetSpec,), _add_dataset)
    _collect(reg, pm, "gym4real_register_baselines", (BaselineSpec,), _add_baseline)
    _collect(reg, pm, "gym4real_register_benchmarks", (BenchmarkSpec, TrainingSpec), _add_benchmark)
    return reg


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


def list_envs(*, strict: bool | None = None) -> list[str]:
    """Return the sorted ids of every installed environment (never raises for a plugin unless strict)."""
    return sorted(registry(strict=strict).envs)


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
    domain = domain_of(env_id)
    failed = [e for e in reg.errors if e.plugin == domain]
    if failed:
        raise EnvUnavailableError(f"environment `{env_id}` is provided by {failed[0]}")
    if env_id in CANONICAL_IDS or (domain in KNOWN_DOMAINS and domain not in reg.distributions):
        from gym4real.core.install_hint import install_command

        dist = KNOWN_DOMAINS.get(domain, f"gym4real-{domain}")
        raise EnvUnavailableError(
            f"environment `{env_id}` is provided by `{dist}`, which is not installed: {install_command(dist)}"
        )
    near = difflib.get_close_matches(env_id, list(reg.envs), n=3, cutoff=0.5)
    hint = f" Did you mean {', '.join(f'`{n}`' for n in near)}?" if near else ""
    raise EnvUnavailableError(f"unknown environment `{env_id}`.{hint} Installed: {sorted(reg.envs)}")


def register_envs() -> list[str]:
    """Register every discovered environment with Gymnasium (string entry points, no heavy import).

    Returns:
        The ids registered by this call (ids already registered with the same entry point are skipped).
    """
    import gymnasium

    done = []

    def register(env_id: str, entry_point: str, kwargs: dict[str, Any], spec: EnvSpec | None = None) -> None:
        old = gymnasium.registry.get(env_id)
        if old is None or old.entry_point != entry_point or old.kwargs != kwargs:
            gymnasium.register(
                id=env_id,
                entry_point=entry_point,
                kwargs=kwargs,
                max_episode_steps=spec.max_episode_steps if spec else None,
                vector_entry_point=spec.vector_entry_point if spec else None,
            )
            done.append(env_id)

    for spec in registry().envs.values():
        register(spec.id, spec.entry_point, dict(spec.kwargs), spec)
        if "multi_objective" in spec.flags:  # the paper's MORL envs also get a vector-reward id
            name, _, version = spec.id.rpartition("-v")
            register(f"{name}-mo-v{version}", MULTI_OBJECTIVE, {"env": spec.id, **spec.kwargs})
    return done
