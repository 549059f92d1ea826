"""The plugin API version rule, the example out-of-tree plugin, and ``gym4real --version``."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
import tomllib
from collections.abc import Callable
from importlib import metadata as importlib_metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement

import gym4real
from gym4real.core import PLUGIN_API_VERSION
from gym4real.core import registry as reg_mod
from gym4real.core.errors import PluginLoadError

ROOT = Path(__file__).resolve().parents[1]
FakePlugins = Callable[..., reg_mod.Registry]


@pytest.fixture
def install(fake_plugins: FakePlugins, plugin_source: Callable[..., str]) -> Callable[[str], reg_mod.Registry]:
    """``install(declaration)``: a fake plugin registering ``gym4real/versioned-v0`` after ``declaration``."""

    def run(declaration: str) -> reg_mod.Registry:
        source = plugin_source(["gym4real/versioned-v0"], declaration=declaration)
        return fake_plugins(
            ("versioned-envs", "2.0", {"versioned": "g4r_fake_versioned"}), modules={"g4r_fake_versioned": source}
        )

    return run


@pytest.mark.parametrize("declared", ["0.3", "1.0", "1.1"])
def test_a_plugin_for_a_newer_api_is_isolated_and_names_the_core_upgrade(
    install: Callable[[str], reg_mod.Registry], declared: str
) -> None:
    reg = install(f'plugin_api = "{declared}"')
    assert "gym4real/versioned-v0" not in reg.envs
    assert "gym4real/elevator-v0" in reg.envs  # every other plugin still loads
    [err] = gym4real.plugin_errors()
    assert (err.plugin, err.distribution, err.phase) == ("versioned", "versioned-envs", "compatibility")
    assert f"plugin API {declared}" in err.error and f"plugin API {PLUGIN_API_VERSION}" in err.error
    assert "pip install -U gym4real-core" in str(err)
    with pytest.raises(PluginLoadError, match="compatibility"):
        reg_mod.registry(strict=True)


def test_a_plugin_for_an_older_major_names_its_own_upgrade(
    install: Callable[[str], reg_mod.Registry], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(reg_mod, "PLUGIN_API_VERSION", "1.0")
    reg = install('plugin_api = "0.1"')
    assert "gym4real/versioned-v0" not in reg.envs
    err = next(e for e in gym4real.plugin_errors() if e.plugin == "versioned")
    assert err.phase == "compatibility" and "pip install -U versioned-envs" in str(err)


@pytest.mark.parametrize("declared", ["0.0", "0.1", PLUGIN_API_VERSION])
def test_a_plugin_for_an_older_or_equal_minor_is_registered(
    install: Callable[[str], reg_mod.Registry], declared: str
) -> None:
    reg = install(f'plugin_api = "{declared}"')
    assert "gym4real/versioned-v0" in reg.envs
    assert gym4real.plugin_errors() == []


@pytest.mark.parametrize("declaration", ["plugin_api = 0.1", 'plugin_api = "latest"', 'plugin_api = "0.1.0"'])
def test_a_malformed_declaration_is_a_compatibility_error(
    install: Callable[[str], reg_mod.Registry], declaration: str
) -> None:
    reg = install(declaration)
    assert "gym4real/versioned-v0" not in reg.envs
    [err] = gym4real.plugin_errors()
    assert err.phase == "compatibility" and "MAJOR.MINOR" in err.error and "versioned-envs" in err.fix


def test_a_plugin_that_declares_nothing_is_registered_with_a_warning(
    install: Callable[[str], reg_mod.Registry], caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, logger="gym4real.plugins"):
        reg = install("")
    assert "gym4real/versioned-v0" in reg.envs
    assert gym4real.plugin_errors() == []
    [warning] = [r.getMessage() for r in caplog.records if "versioned" in r.getMessage()]
    assert "plugin_api" in warning and "versioned-envs 2.0" in warning


def test_every_installed_domain_declares_the_current_plugin_api() -> None:
    eps = [ep for ep in importlib_metadata.entry_points(group=reg_mod.ENTRY_POINT_GROUP) if ep.dist is not None]
    domains = [ep for ep in eps if ep.dist.name.startswith("gym4real-")]
    assert domains
    for ep in domains:
        assert ep.load().plugin_api == PLUGIN_API_VERSION, ep.dist.name


@pytest.fixture(scope="module")
def example_site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The example plugin (examples/plugin) built and installed into a folder put on PYTHONPATH."""
    pytest.importorskip("hatchling")
    site = tmp_path_factory.mktemp("site")
    cmd = [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", "--target", str(site)]
    subprocess.run([*cmd, str(ROOT / "examples" / "plugin")], check=True)
    return site


def run_with(site: Path, *args: str) -> str:
    env = {**os.environ, "PYTHONPATH": str(site), "GYM4REAL_STRICT_PLUGINS": "1"}
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, check=True, env=env).stdout


def test_the_example_plugin_installs_and_its_env_meets_the_contract(example_site: Path) -> None:
    code = (
        "import gym4real, gymnasium as gym\n"
        "from gym4real.core.testing import check_contract\n"
        "from gym4real.core.registry import load_object, registry\n"
        "assert 'gym4real/tank-v0' in gym4real.list_envs() and not gym4real.plugin_errors()\n"
        "env = gym4real.make('gym4real/tank-v0')\n"
        "check_contract('gym4real/tank-v0')\n"
        "policy = load_object(registry().baselines['gym4real/tank-v0']['refill'].entry_point)(env)\n"
        "obs, _ = env.reset(seed=0)\n"
        "for _ in range(100):\n"
        "    obs, reward, terminated, truncated, _ = env.step(policy(obs))\n"
        "print(env.unwrapped.level, truncated)\n"
    )
    level, truncated = run_with(example_site, "-c", code).split()
    assert truncated == "True"  # the registered 100-step limit
    # once the gap is closed, refill + outflow in [0, 1] keep the level within half the outflow range of 5 m
    assert abs(float(level) - 5.0) <= 0.5 + 1e-5


def test_version_lists_every_installed_gym4real_distribution(example_site: Path) -> None:
    out = run_with(example_site, "-m", "gym4real.cli", "--version").splitlines()
    expected = [f"gym4real-core {_pyproject_version('gym4real-core')} (plugin API {PLUGIN_API_VERSION})"]
    installed = {d.name for d in importlib_metadata.distributions()}
    domains = sorted(p.parent.name for p in ROOT.glob("packages/gym4real-*/pyproject.toml"))
    expected += [f"{d} {_pyproject_version(d)}" for d in domains if d != "gym4real-core" and d in installed]
    assert out == [expected[0], *sorted([*expected[1:], "gym4real-example-tank 0.1.0"])]


def _pyproject_version(dist: str) -> str:
    return tomllib.loads((ROOT / "packages" / dist / "pyproject.toml").read_text())["project"]["version"]


#: Record fields each minor of the plugin API added (docs/plugins.md, "Versions").
ADDED_IN = {(0, 2): {"BenchmarkSpec": ("step_unit", "claims"), "TrainingSpec": ("budget",)}}


def _api(text: str) -> tuple[int, int]:
    major, minor = text.split(".")
    return int(major), int(minor)


@pytest.mark.parametrize("domain", ["dam", "elevator", "microgrid", "robofeeder", "trading", "wds"])
def test_each_domain_declares_the_plugin_api_of_the_fields_it_uses(domain: str) -> None:
    # a domain that sets a field of API 0.2 while declaring 0.1 installs beside core 0.1 and breaks there
    module = pytest.importorskip(f"gym4real.{domain}._plugin")
    declared = _api(module.plugin_api)
    records = module.gym4real_register_benchmarks()
    for api, fields in ADDED_IN.items():
        for record in records:
            for name in fields.get(type(record).__name__, ()):
                default = type(record).__dataclass_fields__[name].default
                if getattr(record, name) != default:
                    assert declared >= api, f"{domain} sets {type(record).__name__}.{name} but declares {declared}"


@pytest.mark.parametrize("domain", ["dam", "elevator", "microgrid", "robofeeder", "trading", "wds"])
def test_each_domain_requires_a_core_that_serves_its_plugin_api(domain: str) -> None:
    project = tomllib.loads((ROOT / "packages" / f"gym4real-{domain}" / "pyproject.toml").read_text())["project"]
    [core] = [r for r in map(Requirement, project["dependencies"]) if r.name == "gym4real-core"]
    module = pytest.importorskip(f"gym4real.{domain}._plugin")
    oldest = min(_api(s.version) for s in core.specifier if s.operator == ">=")
    assert oldest >= _api(module.plugin_api)  # core M.m serves plugin API M.m (docs/plugins.md table)
    assert core.specifier.contains(importlib_metadata.version("gym4real-core"))  # the checkout core is in range
