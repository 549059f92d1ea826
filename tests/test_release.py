"""The release checks of scripts/release.py, and the metadata each distribution needs on a public index."""

from __future__ import annotations

import re
import subprocess
import tomllib
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = sorted(p.parent for p in (ROOT / "packages").glob("*/pyproject.toml"))


@pytest.fixture(scope="module")
def script(load_script: Callable[[Path], ModuleType]) -> ModuleType:
    return load_script(ROOT / "scripts" / "release.py")


@pytest.fixture
def repo(tmp_path: Path) -> Path:
    """A git repository with release tags of gym4real-wds (0.1.0) and gym4real-core (0.1.0, 0.1.1, 0.2.0)."""

    def git(*args: str) -> None:
        ident = ["-c", "user.name=t", "-c", "user.email=t@example.org"]
        subprocess.run(["git", *ident, *args], cwd=tmp_path, check=True, capture_output=True)

    git("init", "-q")
    git("commit", "-q", "--allow-empty", "-m", "first")
    for tag in ["gym4real-wds-v0.1.0", "gym4real-core-v0.1.0", "gym4real-core-v0.1.1", "gym4real-core-v0.2.0"]:
        git("tag", "-a", tag, "-m", tag)
    git("tag", "-a", "gym4real-core-vnext", "-m", "not a version")
    return tmp_path


def test_a_version_that_is_not_newer_than_the_last_tag_fails(script: ModuleType, repo: Path) -> None:
    for version in ["0.1.0", "0.0.9"]:
        with pytest.raises(script.ReleaseError, match=r"gym4real-wds-v0\.1\.0.*bump `version`"):
            script.check_version("gym4real-wds", version, root=repo)
    script.check_version("gym4real-wds", "0.1.1", root=repo)
    script.check_version("gym4real-dam", "0.1.0", root=repo)  # never released: any version


def test_the_core_releases_in_range_come_from_the_dependency_and_the_tags(
    script: ModuleType, repo: Path, tmp_path: Path
) -> None:
    (tmp_path / "pyproject.toml").write_text('[project]\ndependencies = ["numpy", "gym4real-core>=0.1.1,<0.2"]\n')
    found = script.core_releases_in(script.core_range(tmp_path), root=repo)
    assert found == {script.Version("0.1.1"): "gym4real-core-v0.1.1"}
    found = script.core_releases_in(script.SpecifierSet(">=0.1,<0.2"), root=repo)
    assert next(iter(found.items())) == (script.Version("0.1.0"), "gym4real-core-v0.1.0")  # the oldest first
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "x"\ndependencies = ["numpy"]\n')
    with pytest.raises(script.ReleaseError, match="does not depend on gym4real-core"):
        script.core_range(tmp_path)


def test_the_changelog_needs_the_version_as_its_newest_section(script: ModuleType, tmp_path: Path) -> None:
    path = tmp_path / "gym4real-wds"
    path.mkdir()
    with pytest.raises(script.ReleaseError, match=r"no section for 0\.1\.1"):
        script.check_changelog(path, "0.1.1")
    (path / "CHANGELOG.md").write_text("# Changelog\n\n## [Unreleased]\n\n- x\n\n## [0.1.0] - 2026-11-23\n")
    with pytest.raises(script.ReleaseError, match=r"no section for 0\.1\.1: rename `## \[Unreleased\]`"):
        script.check_changelog(path, "0.1.1")
    (path / "CHANGELOG.md").write_text("## [0.1.0] - 2026-11-23\n\n## [0.1.1] - 2026-12-01\n")
    with pytest.raises(script.ReleaseError, match="must be the newest"):
        script.check_changelog(path, "0.1.1")
    (path / "CHANGELOG.md").write_text("## [Unreleased]\n\n## [0.1.1] - 2026-12-01\n\n## [0.1.0] - 2026-11-23\n")
    script.check_changelog(path, "0.1.1")


@pytest.mark.parametrize("path", PACKAGES, ids=[p.name for p in PACKAGES])
def test_each_distribution_has_what_a_public_index_needs(script: ModuleType, path: Path) -> None:
    trove = pytest.importorskip("trove_classifiers")
    meta = tomllib.loads((path / "pyproject.toml").read_text())["project"]
    assert meta["license"] == "Apache-2.0"
    assert "Apache License\n                           Version 2.0" in (path / "LICENSE").read_text()
    assert meta["keywords"] and meta["urls"]
    assert meta["classifiers"] and set(meta["classifiers"]) <= trove.classifiers
    assert not any(c.startswith("License ::") for c in meta["classifiers"])  # PEP 639: the SPDX field only
    readme = (path / meta["readme"]).read_text()
    assert not re.search(r"\]\((?!https?://|#)", readme), "a relative link is broken on the index page"
    script.check_changelog(path, meta["version"])  # the current version has its section
