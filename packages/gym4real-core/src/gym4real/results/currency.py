"""``gym4real reproduce --stale``: rerun only the results sections that are not current.

A section is stale when a fingerprint of what its numbers depend on changed
(:mod:`gym4real.results.fingerprints`). When only the test protocol changed, its finished training runs
are tested again; when its data or trainer changed (or it recorded no fingerprints), its runs folder
``OUT/<env>/<budget>/runs`` is moved aside (``runs.stale-<UTC time>``, kept for comparison) and every run
trains again.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from pathlib import Path

from gym4real.core.errors import Gym4RealError
from gym4real.results.fingerprints import section_changes
from gym4real.core.registry import slug


class StaleResultsError(Gym4RealError):
    """Some results sections are not current with the installed code (``reproduce --check``)."""


#: Changes that only need the finished runs tested again.
RETEST_ONLY = ("protocol",)


def needs_training(found: list[str]) -> bool:
    """Whether the changes that make a section stale change its training runs (not only its test phase)."""
    return any(not change.startswith(RETEST_ONLY) for change in found)


def reproduce_stale(
    out: Path,
    env_ids: Sequence[str] = (),
    n_seeds: int | None = None,
    page: str | Path | None = None,
    jobs: int = 1,
) -> str:
    """Rerun every stale section of ``out`` (of ``env_ids`` only, if given); a text report.

    Args:
        out: An output folder of ``gym4real reproduce`` (its sections and their runs).
        env_ids: Only these environments' sections (default: every section of ``out``).
        n_seeds: Seeds per algorithm (default: as many as the section had).
        page: Also write the results page into this folder.
        jobs: Training runs at a time.
    """
    from gym4real.results.reproduce import reproduce
    from gym4real.results.results_page import FOLDER

    if not out.is_dir():
        raise Gym4RealError(f"`{out}` is not a folder: pass the --out folder of an earlier `gym4real reproduce`")
    lines = []
    for folder in sorted(p for p in out.iterdir() if p.is_dir() and FOLDER.match(p.name)):
        report_path = folder / "report.json"
        if not report_path.exists():
            lines.append(f"{folder.name}: no report.json; run `gym4real reproduce` for it")
            continue
        report = json.loads(report_path.read_text())
        env_id, budget = report["env_id"], report["budget"]
        if env_ids and env_id not in env_ids:
            continue
        found = section_changes(folder)
        if not found:
            lines.append(f"{folder.name}: current, not rerun")
            continue
        runs = out / slug(env_id) / budget / "runs"
        moved = ""
        if needs_training(found) and runs.exists():
            aside = runs.with_name(f"runs.stale-{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}")
            runs.rename(aside)
            moved = f"; its runs moved to {aside.name} and trained again"
        lines.append(f"{folder.name}: stale ({'; '.join(found)}){moved}")
        seeds = n_seeds if n_seeds is not None else len(report["seeds"]) or None
        lines.append(reproduce([env_id], budget, seeds, out, page=page, jobs=jobs))
    return "\n".join(lines)


def check(out: str | Path) -> tuple[list[str], list[str]]:
    """``reproduce --check``: one line per results section of ``out``, and the stale sections' names."""
    from gym4real.results.results_page import FOLDER

    out = Path(out)
    if not out.is_dir():
        raise Gym4RealError(f"`{out}` is not a folder: pass the output folder of `gym4real reproduce` or a page folder")
    lines, stale = [], []
    for folder in sorted(p for p in out.iterdir() if p.is_dir() and FOLDER.match(p.name)):
        found = section_changes(folder)
        lines.append(f"{folder.name}: current" if not found else f"{folder.name}: stale: {'; '.join(found)}")
        if found:
            stale.append(folder.name)
    if not lines:
        raise Gym4RealError(f"`{out}` holds no results section (`<env>-<budget>/`)")
    return lines, stale
