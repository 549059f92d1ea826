"""The ``pip install`` that provides a gym4real distribution, from where core itself was installed.

The domain distributions are not on PyPI yet: a core installed from a checkout gets the path of the
domain in that same checkout; any other install gets both forms.
"""

from __future__ import annotations

import json
from pathlib import Path
from urllib.parse import unquote, urlparse

import importlib_metadata


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
