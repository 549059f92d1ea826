"""The ``pip install`` that provides a gym4real distribution, a library one of them needs, or an extra of core.

The domain distributions are not on PyPI yet: a core installed from a checkout gets the path of the
domain in that same checkout; any other install gets both forms. A library a distribution declares but
that is not installed (a ``pip install --no-deps``, an uninstall) is named with the ``pip install`` of the
requirement as the distribution declares it (:func:`unmet_requirements`, :func:`missing_dependency`).
What only measurement, training and publishing need (matplotlib, scipy, tqdm) is the ``bench`` extra of
gym4real-core, so that a domain's user installs a thin core: :func:`require_extra` and :func:`import_extra`
name the extra to install.
"""

from __future__ import annotations

import importlib
import json
from importlib import metadata as importlib_metadata
from pathlib import Path
from types import ModuleType
from urllib.parse import unquote, urlparse

from packaging.requirements import InvalidRequirement, Requirement

from gym4real.core.errors import MissingDependencyError


def _core_checkout() -> tuple[Path, bool] | None:
    """``(packages folder, editable)`` when core was installed from a folder of a checkout, else None."""
    try:
        raw = importlib_metadata.distribution("gym4real-core").read_text("direct_url.json")
    except importlib_metadata.PackageNotFoundError:
        return None
    if not raw:
        return None
    try:
        record = json.loads(raw)
    except json.JSONDecodeError:
        return None
    url = urlparse(str(record.get("url", "")))
    if url.scheme != "file" or "dir_info" not in record:
        return None
    return Path(unquote(url.path)).parent, bool(record["dir_info"].get("editable"))


def _in_checkout(dist: str) -> tuple[Path, bool] | None:
    """The folder of ``dist`` in the checkout core was installed from, and whether core is editable; else None."""
    checkout = _core_checkout()
    if checkout is not None and (checkout[0] / dist / "pyproject.toml").is_file():
        return checkout[0] / dist, checkout[1]
    return None


def install_command(dist: str) -> str:
    """Return the command that installs ``dist`` (``gym4real-dam``) beside this core."""
    found = _in_checkout(dist)
    if found is not None:
        folder, editable = found
        return f"`pip install {'-e ' if editable else ''}{folder}` (from the checkout core came from)"
    return f"`pip install ./packages/{dist}` from a gym4real checkout, or `pip install {dist}` once it is on PyPI"


def _requirements(dist: importlib_metadata.Distribution) -> list[Requirement]:
    """The requirements ``dist`` declares for this interpreter and platform, extras left out."""
    found = []
    for text in dist.requires or ():
        try:
            req = Requirement(text)
        except InvalidRequirement:
            continue
        if req.marker is None or req.marker.evaluate({"extra": ""}):
            found.append(req)
    return found


def _unmet(req: Requirement) -> bool:
    try:
        version = importlib_metadata.version(req.name)
    except importlib_metadata.PackageNotFoundError:
        return True
    return not req.specifier.contains(version, prereleases=True)


def unmet_requirements(dist: importlib_metadata.Distribution) -> list[str]:
    """The requirements of an installed distribution (as it declares them) that no installed version meets."""
    return [str(req) for req in _requirements(dist) if _unmet(req)]


def pip_install(requirements: list[str]) -> str:
    """``pip install "mujoco<5,>=4" ...``: the command that installs ``requirements`` (quoted for a shell)."""
    return "pip install " + " ".join(f'"{r}"' for r in requirements)


def missing_dependency(dist: str, requirement: str, module: str) -> MissingDependencyError:
    """The error of ``import module`` failing in ``dist`` because its requirement ``requirement`` is not installed.

    Args:
        dist: The distribution that imports it (``gym4real-robofeeder``).
        requirement: The distribution it declares for it (``opencv-python-headless``).
        module: The module that could not be imported (``cv2``).
    """
    what = f"`{module}`" if module == requirement else f"`{module}` (distribution {requirement})"
    command = pip_install([declared_requirement(dist, requirement)])
    return MissingDependencyError(f"{dist} needs {what}, which is not installed: `{command}`")


def declared_requirement(dist: str, name: str) -> str:
    """The requirement ``name`` as the installed ``dist`` declares it (``mujoco<5,>=4``); ``name`` if it does not."""
    try:
        declared = _requirements(importlib_metadata.distribution(dist))
    except importlib_metadata.PackageNotFoundError:
        return name
    return next((str(r) for r in declared if r.name == name), name)


def require(module: str, dist: str, requirement: str) -> ModuleType:
    """``import module``, or :class:`MissingDependencyError` naming the ``pip install`` of ``requirement`` of ``dist``.

    Only a missing ``module`` (or a missing package above it) is turned into that error; any other failure of its
    import is raised as it is.
    """
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if not _is_missing(module, exc):
            raise
        raise missing_dependency(dist, requirement, module) from None


def _is_missing(module: str, exc: ModuleNotFoundError) -> bool:
    """Whether ``exc`` says that ``module`` itself, or a package above it, is missing (not a module it imports)."""
    return bool(exc.name) and (module == exc.name or module.startswith(f"{exc.name}."))


#: The distribution whose extras hold what only measurement, training and publishing need.
CORE = "gym4real-core"


def _canonical(name: str) -> str:
    return name.lower().replace("-", "_").replace(".", "_")


def extras() -> list[str]:
    """The extras gym4real-core declares (``bench``, ``rl``, ...)."""
    try:
        return list(importlib_metadata.metadata(CORE).get_all("Provides-Extra") or [])
    except importlib_metadata.PackageNotFoundError:
        return []


def extra_requirements(extra: str) -> list[Requirement]:
    """The requirements the extra ``extra`` of gym4real-core adds, as core declares them."""
    try:
        declared = importlib_metadata.distribution(CORE).requires or []
    except importlib_metadata.PackageNotFoundError:
        return []
    found = []
    for text in declared:
        req = Requirement(text)
        if req.marker is not None and not req.marker.evaluate({"extra": ""}) and req.marker.evaluate({"extra": extra}):
            found.append(req)
    return found


def extra_command(extra: str) -> str:
    """``pip install "gym4real-core[bench]"``, or the checkout's folder of core when it came from one."""
    found = _in_checkout(CORE)
    if found is not None:
        folder, editable = found
        return f'pip install {"-e " if editable else ""}"{folder}[{extra}]"'
    return f'pip install "{CORE}[{extra}]"'


def extra_error(extra: str, what: str, missing: list[str]) -> MissingDependencyError:
    """``what`` needs the extra ``extra`` of gym4real-core, whose ``missing`` requirements are not installed."""
    return MissingDependencyError(
        f"{what} needs the `{extra}` extra of {CORE} ({', '.join(missing)} not installed): `{extra_command(extra)}`"
    )


def require_extra(extra: str, what: str) -> None:
    """Refuse to go on when a requirement of gym4real-core's extra ``extra`` is not installed.

    Args:
        extra: The extra (``bench``).
        what: What needs it, for the message (```gym4real bench```).

    Raises:
        MissingDependencyError: Naming the missing requirements and the ``pip install`` of the extra.
    """
    missing = [f"{r.name}{r.specifier}" for r in extra_requirements(extra) if r.name != CORE and _unmet(r)]
    if missing:
        raise extra_error(extra, what, missing)


def extra_providing(module: str) -> str | None:
    """The extra of gym4real-core that brings the top-level package of ``module`` (``scipy.stats`` -> ``bench``)."""
    top = _canonical(module.split(".")[0])
    return next((e for e in extras() if any(_canonical(r.name) == top for r in extra_requirements(e))), None)


def import_extra(module: str, extra: str) -> ModuleType:
    """``import module``, which gym4real-core's extra ``extra`` brings, or the error naming that extra.

    Raises:
        MissingDependencyError: ``module`` (or a package above it) is not installed: the ``pip install`` of the
            extra. Any other failure of the import is raised as it is.
    """
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if not _is_missing(module, exc):
            raise
        raise extra_error(extra, f"`import {module}`", [str(exc.name).split(".")[0]]) from None
