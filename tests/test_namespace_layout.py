"""Only core owns ``gym4real/__init__.py``; every distribution has the same skeleton."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

PACKAGES = Path(__file__).resolve().parents[1] / "packages"
DISTS = sorted(p.parent for p in PACKAGES.glob("*/pyproject.toml"))
DOMAINS = [d for d in DISTS if d.name != "gym4real-core"]


def test_core_and_at_least_one_domain_exist() -> None:
    assert PACKAGES / "gym4real-core" in DISTS
    assert DOMAINS


def test_only_core_ships_the_namespace_init() -> None:
    inits = sorted(p.relative_to(PACKAGES) for p in PACKAGES.glob("*/src/gym4real/__init__.py"))
    assert inits == [Path("gym4real-core/src/gym4real/__init__.py")]


@pytest.mark.parametrize("dist", DOMAINS, ids=lambda d: d.name)
def test_domain_skeleton(dist: Path) -> None:
    domain = dist.name.removeprefix("gym4real-")
    meta = tomllib.loads((dist / "pyproject.toml").read_text())
    project = meta["project"]
    assert project["name"] == dist.name
    assert project["version"].startswith("0.")
    core = tomllib.loads((PACKAGES / "gym4real-core" / "pyproject.toml").read_text())["project"]["version"]
    major, minor = (int(p) for p in core.split(".")[:2])
    series = f"gym4real-core>={major}.{minor},<{major}.{minor + 1}"  # the in-tree core's minor series
    assert any(d.replace(" ", "").startswith(series) for d in project["dependencies"])
    assert project["entry-points"]["gym4real.plugins"] == {domain: f"gym4real.{domain}._plugin"}
    wheel = meta["tool"]["hatch"]["build"]["targets"]["wheel"]
    assert wheel["only-include"] == [f"src/gym4real/{domain}"]
    leaf = dist / "src" / "gym4real" / domain
    for name in ("__init__.py", "_plugin.py", "py.typed", "config.py", "env.py", "baselines.py", "evaluation.py"):
        assert (leaf / name).exists(), f"{dist.name} lacks {name}"
    assert list((leaf / "presets").glob("*.yaml")), f"{dist.name} has no presets"
    assert (dist / "README.md").exists() and (dist / "tests").is_dir()


def test_test_basenames_are_unique() -> None:
    names = [p.name for p in PACKAGES.glob("*/tests/test_*.py")]
    assert len(names) == len(set(names))
