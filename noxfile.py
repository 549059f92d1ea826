"""Sessions of the gym4real monorepo.

* ``tests``: every package editable in one venv, all test suites (the README's test command; CI runs it).
* ``tests-<dist>``: one distribution with core only, in its own venv, its own suite.
* ``wheels``: build every wheel, install them into a fresh venv, smoke-test each domain.
* ``minimal``: core alone lists no env and names the pip install of a missing domain.
* ``lint`` (ruff) and ``typecheck`` (mypy).
"""

from __future__ import annotations

import os
from pathlib import Path

import nox

ROOT = Path(__file__).resolve().parent
PACKAGES = sorted(p.parent for p in (ROOT / "packages").glob("*/pyproject.toml"))
DOMAINS = [p for p in PACKAGES if p.name != "gym4real-core"]
CORE = ROOT / "packages" / "gym4real-core"
TORCH = "torch==2.13.0"  # the CPU build; a plain `torch` pulls a multi-GB CUDA build

nox.options.default_venv_backend = "venv"
nox.options.sessions = ["lint", "tests"]
nox.options.error_on_missing_interpreters = False

ENV = {
    "GYM4REAL_DATA_DIR": os.environ.get("GYM4REAL_DATA_DIR", str(ROOT.parent / "shared" / "data")),
    "GYM4REAL_STRICT_PLUGINS": "1",
    "GYM4REAL_OFFLINE": "1",
    "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
    "OMP_NUM_THREADS": "1",
    "MPLBACKEND": "Agg",
}


def _test_deps(dist: Path) -> list[str]:
    return list(nox.project.dependency_groups(nox.project.load_toml(dist / "pyproject.toml"), "test"))


def _editable(dist: Path) -> str:
    return f"-e{dist}[rl,mo,offline]" if dist == CORE else f"-e{dist}"


@nox.session
@nox.parametrize("gymnasium", ["latest", "1.2.2"])
def tests(session: nox.Session, gymnasium: str) -> None:
    """All packages editable in one venv; every suite, on the latest gymnasium and on 1.2.2.

    The 1.2.2 run installs Ray RLlib (which pins it) and so also runs the RLlib test.
    """
    session.install(TORCH)
    session.install(*(_editable(d) for d in PACKAGES))
    session.install(
        *sorted({dep for d in PACKAGES for dep in _test_deps(d)}),
        "pytest-xdist>=3",
        "hatchling>=1.26",
        "mkdocs-material>=9.5",
    )
    if gymnasium != "latest":
        session.install(f"gymnasium=={gymnasium}", f"-e{CORE}[ray]")
    suites = ["tests", *(str(d / "tests") for d in PACKAGES)]
    session.run("pytest", "-n", "2", "--dist", "loadfile", *suites, *session.posargs, env=ENV)


def _tests_of(dist: Path) -> None:
    def session_fn(session: nox.Session) -> None:
        if dist != CORE:
            session.install(f"-e{CORE}")
        session.install(f"-e{dist}", *_test_deps(dist))
        listed = str(session.run("python", "-m", "pip", "list", "--exclude-editable", silent=True) or "")
        if "gym4real" in listed:
            session.error("a gym4real distribution came from an index instead of this checkout")
        session.run("pytest", str(dist / "tests"), *session.posargs, env=ENV)

    session_fn.__doc__ = f"{dist.name} in a venv of its own with core: its declared dependencies suffice."
    nox.session(name=f"tests-{dist.name.removeprefix('gym4real-')}")(session_fn)


for _dist in PACKAGES:
    _tests_of(_dist)


@nox.session
def bench(session: nox.Session) -> None:
    """The main job: `gym4real bench` (args after `--`, default the elevator) with a table and figures."""
    session.install(*(_editable(d).removesuffix("[rl,mo,offline]") for d in PACKAGES))
    args = session.posargs or ["gym4real/elevator-v0"]
    session.run("gym4real", "bench", *args, env={k: v for k, v in ENV.items() if k != "GYM4REAL_OFFLINE"})


@nox.session
def docs(session: nox.Session) -> None:
    """The docs site: one generated page per env with its `gym4real bench` figures (short benchmarks)."""
    session.install(*(_editable(d).removesuffix("[rl,mo,offline]") for d in PACKAGES), "mkdocs-material>=9.5")
    figures = ROOT / "results" / "docs"
    ids = session.run("python", "-c", "import gym4real; print(*gym4real.list_envs())", silent=True, env=ENV)
    for env_id in str(ids).split():
        out = figures / env_id.replace("/", "_")
        session.run("gym4real", "bench", env_id, "--episodes", "3", "--out", str(out), "--quiet", env=ENV)
    session.run("python", "docs/gen_pages.py", "--figures", str(figures), env=ENV)
    session.run("mkdocs", "build", "--strict", env=ENV)


@nox.session
def wheels(session: nox.Session) -> None:
    """Build every wheel, install them (not editable) into this venv, import every domain."""
    out = Path(session.create_tmp()) / "dist"
    session.install("build", "hatchling>=1.26")
    for dist in PACKAGES:
        session.run("python", "-m", "build", "--wheel", "--no-isolation", "--outdir", str(out), str(dist))
    session.install(*(str(w) for w in sorted(out.glob("*.whl"))))
    code = (
        "import gym4real, importlib; ids = gym4real.list_envs(); print(ids); "
        f"[importlib.import_module('gym4real.' + d) for d in {[d.name.removeprefix('gym4real-') for d in DOMAINS]!r}]; "
        "assert not gym4real.plugin_errors(), gym4real.plugin_errors()"
    )
    session.run("python", "-c", code, env=ENV)


@nox.session
def minimal(session: nox.Session) -> None:
    """Core alone: no environment, and an id of a missing domain names its pip install."""
    session.install(str(CORE))
    code = (
        "import gym4real; assert gym4real.list_envs() == [], gym4real.list_envs()\n"
        "try:\n    gym4real.make('gym4real/dam-v0')\n"
        "except gym4real.core.EnvUnavailableError as e:\n    assert 'pip install gym4real-dam' in str(e); print(e)\n"
        "else:\n    raise SystemExit('expected EnvUnavailableError')\n"
    )
    session.run("python", "-c", code, env=ENV)


@nox.session
def lint(session: nox.Session) -> None:
    """Ruff lint and format check over the whole repository."""
    session.install("ruff")
    session.run("ruff", "check", ".")
    session.run("ruff", "format", "--check", ".")


@nox.session
def typecheck(session: nox.Session) -> None:
    """mypy over every package's sources."""
    session.install("mypy", "types-PyYAML", *(f"-e{d}" for d in PACKAGES))
    session.run("mypy", *(str(d / "src" / "gym4real") for d in PACKAGES))
