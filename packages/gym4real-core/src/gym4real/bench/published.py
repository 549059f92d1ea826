"""A published model checked against the listing of the results section that publishes it.

A results section publishes each trained model in ``<section>/models/<algo>-seed<S>/`` and lists the files
of each with their SHA-256 in ``<section>/models.json`` (:mod:`gym4real.results.published_models`). A model
file that ``gym4real evaluate`` or ``gym4real bench`` is given from such a folder is scored as that published
model only when every file of its folder has the listed bytes: :func:`check_published` refuses it otherwise,
naming the file, the SHA-256 listed and the one found, and the fix. A model anywhere else is not checked.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from gym4real.core.datasets import sha256_of
from gym4real.core.errors import PolicyError

#: The folder of the published models inside a results section.
FOLDER = "models"
#: The listing of a section's models, beside that folder.
LISTING = "models.json"


def listing_of(model: str | Path) -> Path | None:
    """The ``models.json`` of the results section whose ``models/`` folder holds ``model``, or None."""
    folder = Path(model).resolve().parent  # <section>/models/<algo>-seed<S>/
    if folder.parent.name != FOLDER:
        return None
    listing = folder.parent.parent / LISTING
    return listing if listing.is_file() else None


def _shown(path: Path) -> str:
    """``path`` as the user would name it: relative to the working folder."""
    return os.path.relpath(path)


def _fix(model: Path, entry: dict[str, Any]) -> str:
    retrain = f", or train it again (`{entry['retrain']}`)" if entry.get("retrain") else ""
    return (
        f"restore the published files (`git checkout -- {_shown(model.parent)}` in a checkout of the repository, or "
        f"copy them from its release){retrain}; to evaluate a changed model on purpose, copy its folder out of the "
        "results folder"
    )


def _entry(model: Path, listing: Path) -> dict[str, Any]:
    """The listing's record of ``model`` (its ``path`` relative to the section); refused when none is readable."""
    section = listing.parent
    shown = _shown(listing)
    try:
        entries = json.loads(listing.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise PolicyError(
            f"`{shown}` cannot be read ({' '.join(str(exc).split())}), so the published model `{model}` cannot be "
            f"checked against its SHA-256: restore it (`git checkout -- {shown}` in a checkout of the repository)"
        ) from exc
    relative = model.resolve().relative_to(section.resolve()).as_posix()
    listed = entries if isinstance(entries, list) else []
    found = [e for e in listed if isinstance(e, dict) and e.get("path") == relative]
    if not found or not isinstance(found[0].get("files"), list):
        raise PolicyError(
            f"`{model}` lies in the published models of `{section.name}`, but `{shown}` lists no model with its files "
            f"at `{relative}`: it is not a published model; to evaluate it as your own, copy its folder out of the "
            "results folder"
        )
    entry: dict[str, Any] = found[0]
    return entry


def check_published(model: str | Path) -> None:
    """Refuse a model inside a results section's ``models/`` whose files differ from ``models.json``.

    Every file the listing names for the model (the model and the normalisation statistics loaded with it)
    must be there with its listed SHA-256, and no other file may lie in the model's folder (a loader would
    read a ``normalize.npz`` put there).

    Raises:
        PolicyError: A listed file missing or changed (its expected and actual SHA-256), a file the listing
            does not name, an unreadable listing, or a model the listing does not list; each with the fix.
    """
    model = Path(model)
    listing = listing_of(model)
    if listing is None:
        return
    entry = _entry(model, listing)
    shown = _shown(listing)
    what = f"published model {entry.get('algo', '?')} seed {entry.get('seed', '?')} of `{listing.parent.name}`"
    listed = {str(f.get("name")): str(f.get("sha256")) for f in entry["files"] if isinstance(f, dict)}
    for name, expected in listed.items():
        file = model.parent / name
        if not file.is_file():
            raise PolicyError(f"`{_shown(file)}` of the {what} is missing: `{shown}` lists it: {_fix(model, entry)}")
        actual = sha256_of(file)
        if actual != expected:
            raise PolicyError(
                f"`{_shown(file)}` is not the file of the {what}: `{shown}` lists SHA-256 {expected}, the file has "
                f"{actual}, so its scores would not be the published ones: {_fix(model, entry)}"
            )
    extra = sorted(p.name for p in model.parent.iterdir() if p.name not in listed)
    if extra:
        raise PolicyError(
            f"`{_shown(model.parent)}` holds {', '.join(f'`{n}`' for n in extra)}, which `{shown}` does not list "
            f"for the {what} (a loader would read it with the model): remove it; to evaluate a changed model on "
            "purpose, copy its folder out of the results folder"
        )
