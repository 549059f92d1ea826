"""The provenance lines of a results section: whether it is current, and who trained each run."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pandas as pd

from gym4real.bench.versions import NOT_RECORDED


def currency_line(stale: list[str], verified: dict[str, str] | None = None) -> str:
    """The section's line on its fingerprints (:func:`gym4real.results.fingerprints.section_changes`).

    ``verified``: for a section trained before sections recorded fingerprints, how each recorded one was
    verified (``report.json``'s ``fingerprints_verified``, by ``scripts/verify_fingerprints.py``).
    """
    if not stale:
        line = (
            "**Current**: its test protocol, data and trainer fingerprints equal those of the code that rendered "
            "this page (`gym4real reproduce --check`)."
        )
    else:
        line = f"**Stale** (`gym4real reproduce --check`): {'; '.join(stale)}."
    if verified:
        line += " Fingerprints recorded after the run, each where verified: " + "; ".join(
            f"{part}: {how}" for part, how in verified.items()
        )
        line += "."
    return line


def machine_caveat(report: dict[str, Any]) -> str:
    """The caveat a section's verdicts carry while its rows depend on the machine that ran them, else ``""``.

    Read from ``report.json``'s ``machine_dependent`` (what was measured: which rows another machine scored
    differently); a rerun that finds every row equal on another machine removes that key, and the caveat with it.
    """
    measured = report.get("machine_dependent")
    if not measured:
        return ""
    return f"**caveat**: these rows depend on the machine that ran them ({measured}); the verdict may differ on another"


def _resumes(text: object) -> str:
    """A run's resume record (``runs.csv``'s JSON list) in words."""
    if not isinstance(text, str) or text == NOT_RECORDED:
        return NOT_RECORDED
    resumes = json.loads(text)
    if not resumes:
        return "never"
    return ", ".join(f"at {r['at']:,} {r['unit']} by `{r.get('code_version', '?')}`" for r in resumes)


def run_provenance(runs: pd.DataFrame | None, algo: str, seed: int) -> tuple[str, str]:
    """A run's training commit and resume record, as ``runs.csv`` has them, else :data:`NOT_RECORDED`."""
    if runs is None:
        return NOT_RECORDED, NOT_RECORDED
    row = runs[(runs["algo"] == algo) & (runs["seed"] == int(seed))]
    if not len(row):
        return NOT_RECORDED, NOT_RECORDED
    trained_by = row["trained_by"].iloc[0] if "trained_by" in row else NOT_RECORDED
    trained = f"`{trained_by}`" if isinstance(trained_by, str) and trained_by != NOT_RECORDED else NOT_RECORDED
    return trained, _resumes(row["resumes"].iloc[0] if "resumes" in row else NOT_RECORDED)


def code_versions(runs: pd.DataFrame | None, tested: str) -> str:
    """Where a section's runs were trained (``runs.csv``'s ``trained_by``) and, when elsewhere, its test phase.

    A section tested again at a later commit reuses its runs: the commit of ``report.json`` is the test's.
    Runs recorded before ``runs.csv`` had ``trained_by`` are taken to be the test's commit, as the page said.
    """
    recorded = runs["trained_by"] if runs is not None and "trained_by" in runs else []
    trained = sorted({v for v in recorded if isinstance(v, str) and v != NOT_RECORDED})
    if not trained or trained == [tested]:
        return f"Trained at code version `{tested}`"
    names = ", ".join(f"`{v}`" for v in trained)
    return f"Trained at code version{'s' if len(trained) > 1 else ''} {names} (test phase at `{tested}`)"


def models_lines(folder: Path, name: str) -> list[str]:
    """The section's line on its trained models (``models.json``), and a blank line; none without a listing."""
    listing_path = folder / "models.json"
    if not listing_path.exists():
        return []
    listing = json.loads(listing_path.read_text())
    shipped = [m for m in listing if m["published"]]
    line = (
        f"Models: {len(shipped)} of {len(listing)} published in [`models/`]({name}/models.json) (each with its "
        "SHA-256 and the `gym4real evaluate` command that reruns its test episodes)"
    )
    if len(shipped) < len(listing):
        line += "; the others are listed with why and the `gym4real train` command that trains them again"
    return [line + ".", ""]
