"""``gym4real reproduce --check`` and ``--stale``: whether results sections are current; rerun the stale ones.

``--check`` says of each section of a results folder whether it is current, stale (what changed) or not
checkable here (the data files it read, or its env, are missing here: it names the command that brings
them and its cost), and checks every file of the folder (:mod:`gym4real.results.artefacts`). Its exit
status: 0 when every section is current and every file as listed; 5 when a file is missing, changed,
unknown or unreadable, or a section missing (:class:`~gym4real.results.artefacts.DamagedResultsError`);
else 3 when a section is stale (:class:`StaleResultsError`); else 4 when a section is not checkable here
(:class:`NotCheckableError`); 2 when it cannot run (no such folder).

A section is stale when a fingerprint of what its numbers depend on changed
(:mod:`gym4real.results.fingerprints`). When only the test protocol changed, its finished training runs
are tested again; when its data or trainer changed (or it recorded no fingerprints), its agents' runs
(``OUT/<env>/<budget>/runs/<agent>``) are moved aside (into ``runs.stale-<UTC time>``, kept for comparison)
and every run trains again. A section of the JAX trainer's runs (``<env>-<budget>-jax``) is rerun by that
trainer, and its runs (``runs/ppo-jax``) are moved aside alone: those of the SB3 section stay. ``--stale`` leaves a section that is only not checkable here as it is.
"""

from __future__ import annotations

import os

import json
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from gym4real.core.errors import Gym4RealError
from gym4real.core.registry import slug
from gym4real.results.artefacts import FOLDER, PAGE_FILES, DamagedResultsError, trainer_of, verify
from gym4real.results.fingerprints import not_here, section_changes


class StaleResultsError(Gym4RealError):
    """Some results sections are not current with the installed code (``reproduce --check``, exit status 3)."""

    exit_status = 3


class NotCheckableError(Gym4RealError):
    """Some results sections cannot be checked here: the data they read, or their env, is missing (exit status 4)."""

    exit_status = 4


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
        missing, unavailable = not_here(found)
        if len(missing) + len(unavailable) == len(found):  # nothing changed; what it needs is missing here
            lines.append(
                f"{folder.name}: not checkable here, not rerun: {_not_checkable(folder, missing, unavailable)}"
            )
            continue
        runs = out / slug(env_id) / budget / "runs"
        agents = [runs / agent for agent in report.get("presets", {}) if (runs / agent).exists()]
        moved = ""
        if needs_training(found) and agents:
            aside = runs.with_name(f"runs.stale-{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}")
            aside.mkdir(exist_ok=True)
            for agent in agents:
                agent.rename(aside / agent.name)
            moved = f"; its runs moved to {aside.name} and trained again"
        lines.append(f"{folder.name}: stale ({'; '.join(found)}){moved}")
        seeds = n_seeds if n_seeds is not None else len(report["seeds"]) or None
        lines.append(reproduce([env_id], budget, seeds, out, page=page, jobs=jobs, trainer=trainer_of(folder.name)))
    return "\n".join(lines)


def _data_fix(name: str, recorded: object) -> str:
    """Why a data file that a section read (its recorded SHA-256) is missing here, how to bring it, at what cost.

    A section that read a domain's synthetic stand-in (``gym4real data synthesize``) needs the stand-in; one
    that read the registered file needs that file.
    """
    from gym4real.core.datasets import DATA_DIR_ENV, dataset, stand_in_replacing

    spec, module = dataset(name), stand_in_replacing(name)
    domain = name.split("/", 1)[0]
    if module is not None and recorded != spec.sha256:
        needs = ""
        try:
            module.check_tools()
        except Gym4RealError as exc:
            needs = f"; it needs {' '.join(str(exc).split())}"
        return (
            f"it read the synthetic stand-in of `{name}`, which is not here: `gym4real data synthesize {domain}` "
            f"writes it, with a worker per core, in {module.expected_time(module.HOUSEHOLDS, os.cpu_count() or 1)}"
            f"{needs}"
        )
    return (
        f"it read `{name}` (`{spec.path}`), which is not here: `gym4real data fetch {domain}` downloads it, or set "
        f"{DATA_DIR_ENV} to a folder that holds it (`gym4real data list --urls` gives its address)"
    )


def _not_checkable(folder: Path, missing: list[str], unavailable: list[str]) -> str:
    """Why the section in ``folder`` cannot be checked here, with the commands that make it checkable."""
    if unavailable:
        return "; ".join(unavailable)
    recorded = json.loads((folder / "report.json").read_text(encoding="utf-8")).get("fingerprints", {}).get("data", {})
    return "; ".join(_data_fix(name, recorded.get(name)) for name in missing) + "; then check again"


@dataclass
class Check:
    """What ``reproduce --check`` found: one line per section (and per damaged file), by outcome."""

    out: Path
    lines: list[str] = field(default_factory=list)
    stale: list[str] = field(default_factory=list)
    not_checkable: list[str] = field(default_factory=list)
    damaged: list[str] = field(default_factory=list)
    sections: int = 0

    def raise_for_outcome(self) -> None:
        """Raise the error of the worst outcome: damaged files, then stale sections, then sections not checkable.

        Raises:
            DamagedResultsError: A file missing, changed, unknown or unreadable, or a section missing (exit 5).
            StaleResultsError: A section is stale (exit 3).
            NotCheckableError: A section cannot be checked here, its data or env missing (exit 4).
        """
        if self.damaged:
            named = [f"section {s}" if s != PAGE_FILES else "the page" for s in self.damaged]
            raise DamagedResultsError(
                f"the files of {', '.join(named)} in `{self.out}` are not those published (listed above): "
                f"restore them (`git checkout -- {self.out}` in a checkout of the repository, or from the release "
                "they came with), or render the page again from the output folder of `gym4real reproduce` that made it"
            )
        if self.stale:
            raise StaleResultsError(
                f"{len(self.stale)} of {self.sections} sections are stale ({', '.join(self.stale)}): rerun them with "
                f"`gym4real reproduce --stale --out OUT` on the output folder they came from"
            )
        if self.not_checkable:
            raise NotCheckableError(
                f"{len(self.not_checkable)} of {self.sections} sections cannot be checked here "
                f"({', '.join(self.not_checkable)}): what they need is not here, as said above; the others are current"
            )


def check(out: str | Path) -> Check:
    """``reproduce --check``: each results section of ``out`` current, stale or not checkable here, and its files.

    Every file is checked against ``manifest.json`` and ``models.json`` (:mod:`gym4real.results.artefacts`);
    a section is current, stale (what changed) or not checkable here (the data files it read are not here,
    or its env cannot be made; with the commands that make it checkable).
    """
    out = Path(out)
    if not out.is_dir():
        raise Gym4RealError(f"`{out}` is not a folder: pass the output folder of `gym4real reproduce` or a page folder")
    found = Check(out)
    files = verify(out)
    for folder in sorted(p for p in out.iterdir() if p.is_dir() and FOLDER.match(p.name)):
        found.sections += 1
        try:
            changed = section_changes(folder)
        except DamagedResultsError as exc:
            files.add(folder.name, f"{exc}: its fingerprints cannot be compared")
            continue
        missing, unavailable = not_here(changed)
        if len(missing) + len(unavailable) < len(changed):  # something changed, whatever is missing here
            found.lines.append(f"{folder.name}: stale: {'; '.join(changed)}")
            found.stale.append(folder.name)
        elif missing or unavailable:
            found.lines.append(f"{folder.name}: not checkable here: {_not_checkable(folder, missing, unavailable)}")
            found.not_checkable.append(folder.name)
        else:
            found.lines.append(f"{folder.name}: current")
    if not found.sections and not files.problems:
        raise Gym4RealError(f"`{out}` holds no results section (`<env>-<budget>/`)")
    found.lines += files.lines()
    found.damaged = sorted(files.problems)
    return found
