"""Release checks of one gym4real distribution (``nox -s release -- <dist>``, ``nox -s compat -- <dist>``).

``release <dist>``: the version in ``packages/<dist>/pyproject.toml`` is newer than the last release tag
``<dist>-v<version>``; ``CHANGELOG.md`` has a section for it; the sdist and the wheel (built from the
sdist) build, pass ``twine check --strict`` and hold the licence; the wheel, installed in a fresh venv
with the oldest core release its range admits (core built from that release's tag), passes the
distribution's tests. Then the tag and the upload command are printed; nothing is tagged or uploaded.

``compat <dist>``: the distribution's tests, with its wheel built from the working tree, against each
core release inside its range and against core at HEAD, each core built from a temporary worktree.

Any failed check ends the run with one line ``release: error: ...`` that says what to fix.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import tomllib
import venv
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet
from packaging.version import InvalidVersion, Version

ROOT = Path(__file__).resolve().parents[1]
CORE = "gym4real-core"


class ReleaseError(Exception):
    """A release check failed; the message says what to fix."""


def package_dir(name: str, root: Path = ROOT) -> Path:
    """``packages/gym4real-<name>`` for ``wds``, ``gym4real-wds`` or ``core``."""
    dist = name if name.startswith("gym4real-") else f"gym4real-{name}"
    path = root / "packages" / dist
    if not (path / "pyproject.toml").is_file():
        known = sorted(p.parent.name for p in (root / "packages").glob("*/pyproject.toml"))
        raise ReleaseError(f"no distribution `{name}` in packages/; expected one of {known}")
    return path


def project(path: Path) -> dict[str, Any]:
    """The ``[project]`` table of a distribution's pyproject.toml."""
    table: dict[str, Any] = tomllib.loads((path / "pyproject.toml").read_text())["project"]
    return table


def run(cmd: Sequence[str | Path], what: str, **kwargs: object) -> str:
    """Run ``cmd`` (its output streams through unless captured); a failure is a ReleaseError naming ``what``."""
    print("$", " ".join(map(str, cmd)), flush=True)
    done = subprocess.run([str(c) for c in cmd], text=True, **kwargs)  # type: ignore[call-overload]
    if done.returncode:
        raise ReleaseError(f"{what} failed (exit status {done.returncode}); see the output above")
    return done.stdout or ""


def git(*args: str, root: Path = ROOT) -> str:
    """The output of a git command in ``root``."""
    return subprocess.run(["git", *args], cwd=root, check=True, capture_output=True, text=True).stdout


def releases(dist: str, root: Path = ROOT) -> dict[Version, str]:
    """Released versions of ``dist`` -> their tag, from the tags ``<dist>-v<version>``."""
    out = {}
    for tag in git("tag", "--list", f"{dist}-v*", root=root).split():
        try:
            out[Version(tag.removeprefix(f"{dist}-v"))] = tag
        except InvalidVersion:
            continue
    return dict(sorted(out.items()))


def check_version(dist: str, version: str, root: Path = ROOT) -> None:
    """The version must be newer than the last release tag of ``dist``."""
    done = releases(dist, root)
    last = max(done, default=None)
    if last is not None and Version(version) <= last:
        raise ReleaseError(
            f"{dist} {version} is not newer than its last release {last} (tag {done[last]}): "
            f"bump `version` in packages/{dist}/pyproject.toml"
        )


def check_changelog(path: Path, version: str) -> None:
    """``CHANGELOG.md`` must have a section ``## [<version>]`` (the newest one)."""
    changelog = path / "CHANGELOG.md"
    text = changelog.read_text() if changelog.is_file() else ""
    where = f"packages/{path.name}/CHANGELOG.md"
    sections = re.findall(r"^## \[?([^\]\s]+)\]?", text, flags=re.MULTILINE)
    released = [s for s in sections if s.lower() != "unreleased"]
    fix = f"rename `## [Unreleased]` to `## [{version}] - YYYY-MM-DD` and open a new empty Unreleased section above it"
    if version not in released:
        raise ReleaseError(f"{where} has no section for {version}: {fix}")
    if released[0] != version:
        raise ReleaseError(f"{where}: the section for {version} must be the newest: {fix}")


def build(path: Path, out: Path, *, wheel_only: bool = False) -> list[Path]:
    """Build the sdist and, from it, the wheel of the distribution at ``path`` into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    kind = ["--wheel"] if wheel_only else []
    run([sys.executable, "-m", "build", "--no-isolation", *kind, "--outdir", out, path], f"building {path.name}")
    return sorted(out.iterdir())


def check_licence(files: Sequence[Path]) -> None:
    """The sdist and the wheel must each carry the LICENSE file."""
    for file in files:
        if file.suffix == ".whl":
            names = zipfile.ZipFile(file).namelist()
            ok = any(re.fullmatch(r"[^/]+\.dist-info/licenses/LICENSE", n) for n in names)
        else:
            with tarfile.open(file) as tar:
                ok = any(re.fullmatch(r"[^/]+/LICENSE", n) for n in tar.getnames())
        if not ok:
            raise ReleaseError(f"{file.name} has no LICENSE file: add LICENSE next to its pyproject.toml")


def core_range(path: Path) -> SpecifierSet:
    """The range of gym4real-core a domain depends on."""
    for dep in project(path).get("dependencies", []):
        req = Requirement(dep)
        if req.name == CORE:
            return req.specifier
    raise ReleaseError(f"{path.name} does not depend on {CORE}: declare its range in pyproject.toml")


def core_releases_in(spec: SpecifierSet, root: Path = ROOT) -> dict[Version, str]:
    """The core releases (version -> tag) that ``spec`` admits, oldest first."""
    return {v: tag for v, tag in releases(CORE, root).items() if spec.contains(v, prereleases=True)}


def core_wheel(ref: str, work: Path) -> Path:
    """Build gym4real-core's wheel from the commit ``ref`` (a tag, HEAD) in a temporary worktree."""
    tree = work / f"worktree-{ref}"
    git("worktree", "add", "--detach", str(tree), ref)
    try:
        [wheel] = build(tree / "packages" / CORE, work / f"core-{ref}", wheel_only=True)
    finally:
        git("worktree", "remove", "--force", str(tree))
    return wheel


def test_requirements(path: Path) -> list[str]:
    """The distribution's ``test`` dependency group."""
    groups = tomllib.loads((path / "pyproject.toml").read_text()).get("dependency-groups", {})
    return [dep for dep in groups.get("test", []) if isinstance(dep, str)]


def run_tests_installed(path: Path, wheels: Sequence[Path], work: Path, label: str) -> None:
    """Install ``wheels`` in a fresh venv and run the distribution's tests against them (not the source tree)."""
    env_dir = work / f"venv-{label}"
    venv.create(env_dir, with_pip=True, clear=True)
    python = env_dir / "bin" / "python"
    run([python, "-m", "pip", "install", "-q", *wheels, *test_requirements(path)], f"installing {label}")
    module = "gym4real." + path.name.removeprefix("gym4real-")
    probe = f"import {module} as m, importlib.metadata as md; print(m.__file__); print(md.version('{CORE}'))"
    where, core = run([python, "-c", probe], "importing the wheel", capture_output=True, cwd=work).split()
    if not Path(where).resolve().is_relative_to(env_dir.resolve()):
        raise ReleaseError(f"{module} was imported from {where}, not from the installed wheel")
    print(f"testing {path.name} from {where} with {CORE} {core}", flush=True)
    run([python, "-m", "pytest", "-q", path / "tests"], f"the tests of {path.name} ({label})", cwd=ROOT)


def release(name: str, work: Path) -> None:
    """Every release check of one distribution, then the tag and upload commands."""
    path = package_dir(name)
    meta = project(path)
    dist, version = meta["name"], meta["version"]
    check_version(dist, version)
    check_changelog(path, version)
    if git("status", "--porcelain", "--", str(path)).strip():
        print(f"note: {path.relative_to(ROOT)} has uncommitted changes; commit them before you tag", flush=True)
    files = build(path, work / "dist")
    run([sys.executable, "-m", "twine", "check", "--strict", *files], "twine check --strict")
    check_licence(files)
    wheel = next(f for f in files if f.suffix == ".whl")
    if dist == CORE:
        run_tests_installed(path, [wheel], work, "wheel")
    else:
        spec = core_range(path)
        cores = core_releases_in(spec)
        if not cores:
            raise ReleaseError(f"no {CORE} release inside {dist}'s range `{spec}` (tags {CORE}-v*): release core first")
        oldest, tag = next(iter(cores.items()))
        print(f"oldest {CORE} release in `{spec}`: {oldest} ({tag})", flush=True)
        run_tests_installed(path, [core_wheel(tag, work), wheel], work, f"core-{oldest}")
    out = ROOT / "dist" / f"{dist}-{version}"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    for file in files:
        shutil.copy2(file, out)
    tag = f"{dist}-v{version}"
    print(f"\n{dist} {version}: every release check passed. To publish:")
    print(f'  git tag -a {tag} -m "{dist} {version}" && git push origin {tag}')
    print(f"  python -m twine upload {out.relative_to(ROOT)}/*")


def compat(name: str, work: Path) -> None:
    """One domain's tests against each core release in its range and against core at HEAD."""
    path = package_dir(name)
    dist = project(path)["name"]
    if dist == CORE:
        raise ReleaseError("compat runs a domain against core releases; for core itself use `nox -s release -- core`")
    spec = core_range(path)
    [wheel] = build(path, work / "dist", wheel_only=True)
    head_version = Version(tomllib.loads(git("show", f"HEAD:packages/{CORE}/pyproject.toml"))["project"]["version"])
    cores = [(f"{v} ({tag})", tag) for v, tag in core_releases_in(spec).items()]
    head = f"HEAD {git('rev-parse', '--short', 'HEAD').strip()} ({head_version})"
    if spec.contains(head_version, prereleases=True):
        cores.append((head, "HEAD"))
    else:
        print(f"core at {head} is outside {dist}'s range `{spec}`: not tested", flush=True)
    results = []
    for label, ref in cores:
        print(f"\n=== {dist} against {CORE} {label}", flush=True)
        try:
            run_tests_installed(path, [core_wheel(ref, work), wheel], work, f"core-{ref}")
            results.append((label, "passed"))
        except ReleaseError as exc:
            results.append((label, f"FAILED: {exc}"))
    print(f"\n{dist} against {CORE} (range `{spec}`):")
    for label, outcome in results:
        print(f"  {label}: {outcome}")
    failed = [label for label, outcome in results if outcome != "passed"]
    if failed:
        raise ReleaseError(f"{dist} fails against {CORE} {', '.join(failed)}: fix it, or narrow its range")
    if not any(ref != "HEAD" for _, ref in cores):
        raise ReleaseError(f"no {CORE} release inside `{spec}` was tested (tags {CORE}-v*)")


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``release`` or ``compat``; exit status 1 with one ``release: error:`` line on a failed check."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("command", choices=["release", "compat"])
    parser.add_argument("dist", help="wds, gym4real-wds, core, ...")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix=f"gym4real-{args.command}-") as tmp:
        try:
            (release if args.command == "release" else compat)(args.dist, Path(tmp))
        except ReleaseError as exc:
            print(f"release: error: {exc}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
