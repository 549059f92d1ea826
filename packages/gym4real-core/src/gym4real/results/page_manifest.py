"""What ``manifest.json`` records of each results section: its command, fingerprints, imports, files, models.

Every file a section publishes (its raw data, statistics, figures, ``report.json`` and models) is listed
with its SHA-256, so that a copy of the page can be checked file by file; the distributions are those the
section's runs and test phase imported (``report.json``'s ``imported``), with their versions.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from gym4real.rl.imported import union
from gym4real.results.published_models import LISTING, sha256_of
from gym4real.results.section_provenance import NOT_RECORDED


def files_sha256(files: list[Path], root: Path) -> dict[str, str]:
    """Path relative to ``root`` -> SHA-256, for each file."""
    return {p.relative_to(root).as_posix(): sha256_of(p) for p in sorted(files)}


def section_record(folder: Path, report: dict[str, Any], files: list[Path], stale: list[str]) -> dict[str, Any]:
    """The manifest's record of one results section (``files``: those it publishes)."""
    listing = folder / LISTING
    return {
        "env_id": report["env_id"],
        "command": report["command"],
        "trained_at": report["code_version"],
        "current": not stale,
        "stale": stale,
        "fingerprints": report.get("fingerprints", NOT_RECORDED),
        "imported": report.get("imported", NOT_RECORDED),
        "versions_recorded": report.get("versions", {}),
        "platform": report.get("platform", ""),
        "models": json.loads(listing.read_text()) if listing.exists() else NOT_RECORDED,
        "files": files_sha256(files, folder.parent),
    }


def imported_by_all(records: dict[str, dict[str, Any]]) -> dict[str, str]:
    """Every distribution that some section imported, with its version(s)."""
    return union(*(r["imported"] for r in records.values() if isinstance(r["imported"], dict)))
