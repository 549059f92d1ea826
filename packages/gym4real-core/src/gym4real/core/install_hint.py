"""The ``pip install`` that provides a gym4real distribution, or a library one of them needs.

The domain distributions are not on PyPI yet: a core installed from a checkout gets the path of the
domain in that same checkout; any other install gets both forms. A library a distribution declares but
that is not installed (a ``pip install --no-deps``, an uninstall) is named with the ``pip install`` of the
requirement as the distribution declares it (:func:`unmet_requirements`, :func:`missing_dependency`).
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


def install_command(dist: str) -> str:
    """Return the command that installs ``dist`` (``gym4real-dam``) beside this core."""
    checkout = _core_checkout()
    if checkout is not None and (checkout[0] / dist / "pyproject.toml").is_file():
        folder, editable = checkout
        return f"`pip install {'-e ' if editable else ''}{folder / dist}` (from the checkout core came from)"
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
        if not exc.name or not (module == exc.name or module.startswith(exc.name + ".")):
            raise
        raise missing_dependency(dist, requirement, module) from None
