"""Sessions of the gym4real monorepo.

* ``tests``: every package editable in one venv, all test suites (the README's test command; CI runs it).
* ``tests-<dist>``: one distribution with core only, in its own venv, its own suite.
* ``wheels``: build every wheel, install them into a fresh venv (core without extras: the thin install a
  domain's user gets), smoke-test each domain.
* ``minimal``: core alone lists no env and names the pip install of a missing domain.
* ``bench -- <env id>``: the main job; ``docs`` (``-- --refresh``): the site from the committed results.
* ``lint`` (ruff, import-linter's layers) and ``typecheck`` (mypy).
* ``release -- <dist>`` and ``compat -- <dist>``: release checks of one distribution (RELEASING.md).

Core's ``bench`` extra (matplotlib, scipy, tqdm: measurement, training, publishing) is installed wherever
something measures: ``tests``, ``tests-<dist>`` (each test group names ``gym4real-core[bench]``), ``bench``, ``docs``.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import shutil
from pathlib import Path

import nox

ROOT = Path(__file__).resolve().parent
PACKAGES = sorted(p.parent for p in (ROOT / "packages").glob("*/pyproject.toml"))
DOMAINS = [p for p in PACKAGES if p.name != "gym4real-core"]
CORE = ROOT / "packages" / "gym4real-core"
# The CPU build where the package index serves it (this project's CI machine has it in its wheel house). On
# the public index for Linux this pin is the multi-GB CUDA build: run nox with
# PIP_EXTRA_INDEX_URL=https://download.pytorch.org/whl/cpu to get 2.13.0+cpu instead (the README says so).
TORCH = "torch==2.13.0"
# The docs site's build: the theme, the API reference from docstrings, the executed tutorials, the nav of
# the generated pages (mkdocs.yml); and the browser check's driver (docs/check_site.py).
DOCS = [
    "mkdocs-material>=9.5",
    "mkdocstrings[python]>=0.29",
    "mkdocs-gallery>=0.10",
    "mkdocs-literate-nav>=0.6",
    "ruff",  # mkdocstrings formats the signatures with it
    "import-linter>=2.1",  # the Architecture page draws the layers from its import graph (grimp)
]

nox.options.default_venv_backend = "venv"
nox.options.sessions = ["lint", "tests"]
nox.options.error_on_missing_interpreters = False

SHARED_DATA = ROOT.parent / "shared" / "data"  # the data folder beside a developer's checkout (tests and CI)

ENV = {
    "GYM4REAL_STRICT_PLUGINS": "1",
    "GYM4REAL_OFFLINE": "1",
    "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
    "OMP_NUM_THREADS": "1",
    "MPLBACKEND": "Agg",
}


def _data_env(session: nox.Session) -> dict[str, str]:
    """``GYM4REAL_DATA_DIR``: the user's, else ``../shared/data`` when it exists (said aloud), else unset."""
    if "GYM4REAL_DATA_DIR" in os.environ:
        return {"GYM4REAL_DATA_DIR": os.environ["GYM4REAL_DATA_DIR"]}
    if SHARED_DATA.is_dir():
        session.log(f"GYM4REAL_DATA_DIR is not set: using {SHARED_DATA} (set it to use another data folder)")
        return {"GYM4REAL_DATA_DIR": str(SHARED_DATA)}
    session.log("GYM4REAL_DATA_DIR is not set: data files come from the user cache, downloaded when missing")
    return {}


def _test_deps(dist: Path) -> list[str]:
    return list(nox.project.dependency_groups(nox.project.load_toml(dist / "pyproject.toml"), "test"))


def _editable(dist: Path, extras: str = "bench,rl,jax,mo,offline") -> str:
    """``-e`` install of ``dist``; core with ``extras``."""
    return f"-e{dist}[{extras}]" if dist == CORE and extras else f"-e{dist}"


@nox.session
@nox.parametrize("gymnasium", ["latest", "1.2.2"])
def tests(session: nox.Session, gymnasium: str) -> None:
    """All packages editable in one venv; every suite on the latest gymnasium, and on 1.2.2 all but `slow`.

    The 1.2.2 run installs Ray RLlib (which pins it) and the `cluster` extra (Ray core, pyarrow), and so also
    runs the RLlib test and the tests of `gym4real reproduce --ray` on a local Ray instance (marked `ray`);
    it leaves out the long end-to-end tests (marked `slow`), which the latest run runs.
    """
    session.install(TORCH)
    session.install(*(_editable(d) for d in PACKAGES))
    session.install(
        *sorted({dep for d in PACKAGES for dep in _test_deps(d)}),
        "pytest-xdist>=3",
        "hatchling>=1.26",
        *DOCS,
    )
    if gymnasium != "latest":
        session.install(f"gymnasium=={gymnasium}", f"-e{CORE}[ray,cluster]")
    suites = ["tests", *(str(d / "tests") for d in PACKAGES)]
    # The 1.2.2 run checks the gymnasium API on the floor version: every test but the long end-to-end ones
    # (`slow`, which the latest run has run), and the Ray tests only it can run. CI stays under 30 minutes.
    selection = [] if gymnasium == "latest" else ["-m", "not slow or ray"]
    session.run(
        "pytest",
        "-n",
        "2",
        "--dist",
        "loadfile",
        "-rs",
        *selection,
        *suites,
        *session.posargs,
        env=ENV | _data_env(session),
    )


def _tests_of(dist: Path) -> None:
    def session_fn(session: nox.Session) -> None:
        if dist != CORE:
            session.install(f"-e{CORE}")
        session.install(f"-e{dist}", *_test_deps(dist))
        listed = str(session.run("python", "-m", "pip", "list", "--exclude-editable", silent=True) or "")
        if "gym4real" in listed:
            session.error("a gym4real distribution came from an index instead of this checkout")
        session.run("pytest", "-rs", str(dist / "tests"), *session.posargs, env=ENV | _data_env(session))

    session_fn.__doc__ = f"{dist.name} in a venv of its own with core: its declared dependencies suffice."
    nox.session(name=f"tests-{dist.name.removeprefix('gym4real-')}")(session_fn)


for _dist in PACKAGES:
    _tests_of(_dist)


def _install_current(session: nox.Session, dists: list[Path]) -> None:
    """Install ``dists`` editable (core with its ``bench`` extra), skipping those installed unchanged.

    A stamp in the venv records each installed distribution's ``pyproject.toml``; code changes need no
    reinstall (editable), a changed dependency list does.
    """
    stamp = Path(session.virtualenv.location) / "gym4real-installed.json"
    installed = json.loads(stamp.read_text()) if stamp.exists() else {}
    wanted = {d.name: hashlib.sha256((d / "pyproject.toml").read_bytes()).hexdigest() for d in dists}
    missing = [d for d in dists if installed.get(d.name) != wanted[d.name]]
    if not missing:
        session.log(f"reusing the venv: {', '.join(wanted)} already installed")
        return
    session.log(f"installing {', '.join(d.name for d in missing)} (pip's progress follows)")
    session.install(*(_editable(d, "bench") for d in missing), silent=False)
    stamp.write_text(json.dumps(installed | wanted))


@nox.session(reuse_venv=True)
def bench(session: nox.Session) -> None:
    """The main job: `gym4real bench` (args after `--`, default the elevator) with a table and figures.

    Installs core and the one domain that provides the id (the venv is reused while those are current).
    """
    args = session.posargs or ["gym4real/elevator-v0"]
    env_id = args[0]
    dist = ROOT / "packages" / f"gym4real-{env_id.split('/', 1)[-1].split('-', 1)[0]}"
    if env_id.startswith("-") or dist not in DOMAINS:
        domains = ", ".join(d.name.removeprefix("gym4real-") for d in DOMAINS)
        session.error(
            f"the first argument after `--` must be an env id such as gym4real/elevator-v0 (domains: {domains})"
        )
    _install_current(session, [CORE, dist])
    session.run(
        "gym4real", "bench", *args, env={k: v for k, v in ENV.items() if k != "GYM4REAL_OFFLINE"} | _data_env(session)
    )


#: The env pages' `gym4real bench` results (results.json, summary.csv, episodes.csv, figures), committed:
#: `nox -s docs` builds the pages from them; `nox -s docs -- --refresh` re-runs the benchmarks into it first.
BENCH = ROOT / "docs" / "bench"
#: What the docs session does and how long it takes, said at its start. Measured on a 2-core machine: the build
#: took 92 CPU-seconds (the tutorials about 45, the GIFs 16) and a new venv's installs about 110 more. A fresh
#: clone's whole session at 95dcb61 (load 1.5 to 2, pip's cache warm): 4 min 17 s of wall time, "37 pages, 0 problems".
DOCS_PLAN = (
    "the site from the committed results: the env pages' benchmark figures from docs/bench/ (no benchmark "
    "runs), an episode GIF per env recorded here, `mkdocs build --strict` executing the tutorials of "
    "examples/tutorials/, then every page opened in Chromium. About 1.5 CPU-minutes, plus about 2 for the "
    "installs of a new venv (torch's CPU build, every package, the site's plugins): 4 to 5 minutes on an idle "
    "2-core machine (4 min 17 s measured on a fresh clone), several times that on a busy one"
)
#: The warnings of `mkdocs build`: deprecations shown once per module, as mkdocs shows them, but the one of
#: `mkdocs.utils.warning_filter` (a no-op since MkDocs 1.2), which mkdocs-gallery's compatibility module still
#: imports in its latest release, 0.10.4 (its issue 89): it printed a stack trace on every build.
MKDOCS_WARNINGS = "module::DeprecationWarning,ignore:warning_filter doesn't do anything:DeprecationWarning"
#: Measured: about 45 minutes on an idle 2-core machine; here, busy, robofeeder-planning-v0's alone took 78 minutes
#: (its own figure runs 2 policies x 5 bin sizes x 250 episodes).
DOCS_REFRESH = (
    "first `gym4real bench` of every env into docs/bench/ (--refresh): about 45 minutes on 2 cores, hours on a "
    "busy machine; then "
)


@nox.session
def docs(session: nox.Session) -> None:
    """The docs site from the committed results, checked in a real browser (`-- --refresh`: re-benchmark first).

    One generated page per env with an episode GIF of its best rule-based baseline (recorded here into the
    ignored docs/envs/) and its `gym4real bench` figures on its test protocol, captioned, from the committed
    docs/bench/ (no benchmark runs: `-- --refresh` re-runs `gym4real bench` of every env into it first, about
    45 minutes on 2 cores, and packs its figures; commit the result), plus the home page's gallery, verdicts and
    citation (docs/snippets/); `mkdocs build --strict`, which executes the tutorials of examples/tutorials/ (a
    failing one fails it) and builds the API reference; then every page opened in headless Chromium (the
    system's: `apt-get install -y chromium`, or GYM4REAL_CHROMIUM=<binary>), a screenshot of each saved in
    results/docs/screenshots/ (home.png and env.png: the whole home page and first env page), failing on a
    console error, a broken image, an internal link that does not resolve or a page that does not render.
    The tutorials train with torch: see TORCH above for its CPU build.
    """
    refresh = session.posargs == ["--refresh"]
    if session.posargs and not refresh:
        session.error(f"unknown arguments {session.posargs}: the only option is `-- --refresh` (re-benchmark)")
    spec = importlib.util.spec_from_file_location("check_site", ROOT / "docs" / "check_site.py")
    assert spec is not None and spec.loader is not None
    site_check = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(site_check)  # its lookup of the browser, checked before the long part of the session
    chromium = site_check.find_chromium(None)
    if chromium is None:
        session.error(site_check.INSTALL)
    session.log(f"docs: {DOCS_REFRESH if refresh else ''}{DOCS_PLAN}")
    session.install(TORCH)
    session.install(*(_editable(d) for d in PACKAGES), *DOCS, "playwright>=1.40")
    env = ENV | _data_env(session)
    pages = ["python", "docs/gen_pages.py", "--figures", str(BENCH), "--gifs"]
    if refresh:
        ids = session.run(
            "python", "-c", "import gym4real; print(*gym4real.list_envs(multi_objective=False))", silent=True, env=env
        )
        for env_id in str(ids).split():
            out = BENCH / env_id.replace("/", "_")
            shutil.rmtree(out, ignore_errors=True)
            session.run("gym4real", "bench", env_id, "--out", str(out), "--quiet", env=env)
        pages.append("--pack-figures")
    session.run(*pages, env=env)
    # the notices of the theme and of a plugin about MkDocs 2; the warnings above
    quiet = {"NO_MKDOCS_2_WARNING": "1", "DISABLE_MKDOCS_2_WARNING": "true", "PYTHONWARNINGS": MKDOCS_WARNINGS}
    session.run("mkdocs", "build", "--strict", env=env | quiet)
    shots = ROOT / "results" / "docs" / "screenshots"
    session.run("python", "docs/check_site.py", "site", "--screenshots", str(shots), "--chromium", chromium, env=env)


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
    session.run("python", "-c", code, env=ENV | _data_env(session))


@nox.session
def minimal(session: nox.Session) -> None:
    """Core alone: no environment, and an id of a missing domain names its pip install."""
    session.install(str(CORE))
    code = (
        "import gym4real; assert gym4real.list_envs() == [], gym4real.list_envs()\n"
        "try:\n    gym4real.make('gym4real/dam-v0')\n"
        "except gym4real.core.EnvUnavailableError as e:\n    assert 'packages/gym4real-dam`' in str(e); print(e)\n"
        "else:\n    raise SystemExit('expected EnvUnavailableError')\n"
    )
    session.run("python", "-c", code, env=ENV | _data_env(session))


@nox.session
def lint(session: nox.Session) -> None:
    """Ruff lint and format check over the whole repository; the import layers (import-linter, `.importlinter`)."""
    session.install("ruff", "import-linter>=2.1", *(f"-e{d}" for d in PACKAGES))
    session.run("ruff", "check", ".")
    session.run("ruff", "format", "--check", ".")
    session.run("python", "scripts/lint_imports.py", "--no-cache")


@nox.session
def typecheck(session: nox.Session) -> None:
    """mypy over every package's sources."""
    session.install("mypy", "types-PyYAML", *(_editable(d, "bench") for d in PACKAGES))  # matplotlib's, scipy's types
    session.run("mypy", *(str(d / "src" / "gym4real") for d in PACKAGES))


def _release_script(session: nox.Session, command: str) -> None:
    if len(session.posargs) != 1:
        session.error(f"usage: nox -s {command} -- <dist> (core, dam, elevator, microgrid, robofeeder, trading, wds)")
    session.install("build>=1.2", "twine>=6", "hatchling>=1.26", "packaging>=24")
    session.run("python", "scripts/release.py", command, *session.posargs, env=ENV | _data_env(session))


@nox.session
def release(session: nox.Session) -> None:
    """Check one distribution for release, no upload (`-- wds`): version, changelog, build, twine, wheel tests."""
    _release_script(session, "release")


@nox.session
def compat(session: nox.Session) -> None:
    """One domain's tests against every core release in its range and core at HEAD (`-- dam`)."""
    _release_script(session, "compat")
