"""What ``manifest.json`` records of each results section: its command, fingerprints, imports, machines, files.

Every file a section publishes (its raw data, statistics, figures, ``report.json`` and models) is listed
with its SHA-256, so that a copy of the page can be checked file by file (``gym4real reproduce --check``,
:mod:`gym4real.results.artefacts`); the distributions are those the section's runs and test phase imported
(``report.json``'s ``imported``), with their versions; the machines are the CPU models that trained its runs
(``runs.csv``'s ``cpu`` and each resume's) and that tested them (``report.json``'s ``cpu``). What a section's
files do not record (sections made before the record existed) is said ``not recorded``, never guessed.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from gym4real.bench.published import LISTING
from gym4real.bench.versions import NOT_RECORDED
from gym4real.rl.imported import union
from gym4real.results.provenance import RUNS_TEXT
from gym4real.results.published_models import sha256_of


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
        "machines": machines(folder, report),
        "models": json.loads(listing.read_text()) if listing.exists() else NOT_RECORDED,
        "files": files_sha256(files, folder.parent),
    }


def machines(folder: Path, report: dict[str, Any]) -> dict[str, Any]:
    """The CPU models that trained the section's runs and that tested them, as its files record them.

    ``trained_on``: each CPU model of ``runs.csv`` (the machine that started a run, where recorded, the
    machine that finished it, and the machine of each resume) with its number of runs, ``not recorded`` for
    runs that do not say; ``tested_on``: the test phase's (``report.json``).
    """
    import pandas as pd

    trained: dict[str, int] = {}
    runs = pd.read_csv(folder / "runs.csv", dtype=RUNS_TEXT) if (folder / "runs.csv").exists() else pd.DataFrame()
    for row in runs.to_dict("records"):
        cpus = {str(row.get("cpu", NOT_RECORDED))}
        if isinstance(row.get("started_on"), str) and row["started_on"] != NOT_RECORDED:
            cpus.add(row["started_on"])
        resumes = row.get("resumes")
        if isinstance(resumes, str) and resumes.startswith("["):
            cpus |= {str(r.get("cpu", NOT_RECORDED)) for r in json.loads(resumes)}
        for cpu in cpus:
            trained[cpu] = trained.get(cpu, 0) + 1
    return {"trained_on": dict(sorted(trained.items())) or NOT_RECORDED, "tested_on": report.get("cpu", NOT_RECORDED)}


def imported_by_all(records: dict[str, dict[str, Any]]) -> dict[str, str]:
    """Every distribution that some section imported, with its version(s)."""
    return union(*(r["imported"] for r in records.values() if isinstance(r["imported"], dict)))
