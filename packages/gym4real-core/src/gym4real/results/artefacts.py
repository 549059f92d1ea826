"""Every file of a results folder checked against the SHA-256 that ``manifest.json`` and ``models.json`` list.

``gym4real reproduce --check DIR`` checks what a results folder (a page folder such as ``docs/results``, or
the output folder of ``gym4real reproduce``) publishes, besides whether its sections are current:

- ``manifest.json`` must be readable; every file it lists (each section's data, statistics, figures,
  ``report.json``, ``models.json`` and models; the page's ``index.md``, ``claims.json``, summary figure and,
  with two PPO trainers' sections of an env, ``trainers.json``)
  must be there with its SHA-256;
- every section it lists must be there, and no other: a section folder, or a file inside one, that it does
  not list is unknown; so is, in a page folder, any other file or folder beside the page (an output folder
  holds the training runs and the renderer's ``results.md`` and ``claims.md`` there);
- every published model's files must have the SHA-256 of its section's ``models.json``.

Each problem names the file and its section. A folder with any of them is *damaged*
(:class:`DamagedResultsError`): its numbers are not the published ones, whatever the fingerprints say.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gym4real.bench.published import LISTING
from gym4real.core.datasets import sha256_of
from gym4real.core.errors import Gym4RealError
from gym4real.core.registry import slug
from gym4real.rl.train import TRAINERS

#: The name of a results folder: ``<env>-<budget>``, with ``-<trainer>`` for the runs of a PPO trainer other
#: than SB3 (``<env>-<budget>-jax``: :func:`trainer_of`).
FOLDER = re.compile(
    rf"^(?P<env>[a-z0-9-]+)-(?P<budget>paper|quick)(?:-(?P<trainer>{'|'.join(t for t in TRAINERS if t != 'sb3')}))?$"
)


def trainer_of(name: str) -> str:
    """The trainer of a results folder's runs, from its name: ``sb3``, or ``jax`` for ``<env>-<budget>-jax``."""
    match = FOLDER.match(name)
    return (match["trainer"] if match else None) or "sb3"


def section_name(env_id: str, budget: str, trainer: str = "sb3") -> str:
    """A results section's folder name, as :data:`FOLDER` reads it: ``<env>-<budget>``, ``-jax`` for the JAX trainer."""
    return f"{slug(env_id)}-{budget}" + ("" if trainer == "sb3" else f"-{trainer}")


#: The listing of a results folder's files.
MANIFEST = "manifest.json"
#: The page's text: ``index.md`` in a page folder, ``results.md`` in the output folder it was rendered in.
PAGE, RENDERED = "index.md", "results.md"
#: How a problem names a file beside the sections (the page's own).
PAGE_FILES = "page"
#: Hex digits of a SHA-256 shown in a problem.
SHOWN = 12


class DamagedResultsError(Gym4RealError):
    """A results folder's files differ from its listings: missing, changed, unknown or unreadable (exit status 5)."""

    exit_status = 5


def _short(digest: str) -> str:
    return f"{digest[:SHOWN]}…"


def read_json(path: Path, where: str) -> Any:
    """The JSON of a published file; :class:`DamagedResultsError` naming it (as ``where``) when unreadable."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise DamagedResultsError(f"`{where}` is not UTF-8 text (byte {exc.start}): it is damaged") from exc
    except json.JSONDecodeError as exc:
        raise DamagedResultsError(
            f"`{where}` is not valid JSON ({exc.msg} at line {exc.lineno}): it is damaged"
        ) from exc


@dataclass
class _File:
    """What the listings say of one file and what was found: the SHA-256 each listing gives, the file's own."""

    listed: dict[str, str] = field(default_factory=dict)
    actual: str | None = None
    unknown: bool = False

    def problem(self) -> str | None:
        if self.unknown:
            return f"unknown (not in {MANIFEST})"
        if self.actual is None:
            return f"missing ({' and '.join(self.listed)} list{'s' if len(self.listed) == 1 else ''} it)"
        differ = {where: digest for where, digest in self.listed.items() if digest != self.actual}
        if not differ:
            return None
        agree = [where for where in self.listed if where not in differ]
        return (
            f"changed: {'; '.join(f'{where} lists {_short(digest)}' for where, digest in differ.items())}, "
            f"the file has {_short(self.actual)}"
            + (f" (as {' and '.join(agree)} list{'s' if len(agree) == 1 else ''})" if agree else "")
        )


@dataclass
class Verification:
    """The problems found in a results folder, by section (:data:`PAGE_FILES` for the page's own files)."""

    problems: dict[str, list[str]] = field(default_factory=dict)

    def add(self, section: str, problem: str) -> None:
        """Record ``problem`` under ``section``."""
        self.problems.setdefault(section, []).append(problem)

    def lines(self) -> list[str]:
        """One line per problem: ``<section>: damaged: <file> <what>``."""
        return [f"{section}: damaged: {p}" for section, found in sorted(self.problems.items()) for p in found]


def _manifest(out: Path, found: Verification) -> dict[str, Any] | None:
    """``manifest.json`` if it is there and has the shape the renderer writes, else None (and the problem)."""
    path = out / MANIFEST
    if not path.is_file():
        found.add(PAGE_FILES, f"{MANIFEST} missing: no file of the folder can be checked against it")
        return None
    try:
        manifest = read_json(path, MANIFEST)
    except DamagedResultsError as exc:
        found.add(PAGE_FILES, f"{exc}: no file of the folder can be checked against it")
        return None
    shape = (
        isinstance(manifest, dict)
        and isinstance(manifest.get("files"), dict)
        and isinstance(manifest.get("provenance"), dict)
        and all(isinstance(r, dict) and isinstance(r.get("files"), dict) for r in manifest["provenance"].values())
    )
    if not shape:
        found.add(PAGE_FILES, f"{MANIFEST} lacks the files of the page or of a section: it is damaged")
        return None
    return manifest


def _models(section: Path, files: dict[str, _File], found: Verification) -> None:
    """Each published model's files against its section's ``models.json`` (into ``files``)."""
    listing_path = section / LISTING
    if not listing_path.is_file():
        return
    try:
        listing = read_json(listing_path, f"{section.name}/{LISTING}")
    except DamagedResultsError as exc:
        found.add(section.name, str(exc))
        return
    for model in listing if isinstance(listing, list) else []:
        if not (isinstance(model, dict) and model.get("published") and isinstance(model.get("files"), list)):
            continue
        folder = Path(str(model.get("path", ""))).parent
        for entry in model["files"]:
            relative = f"{section.name}/{(folder / str(entry.get('name'))).as_posix()}"
            files.setdefault(relative, _File()).listed[LISTING] = str(entry.get("sha256"))


def _hash(out: Path, files: dict[str, _File]) -> None:
    for relative, record in files.items():
        path = out / relative
        if path.is_file():
            record.actual = sha256_of(path)


def verify(out: str | Path) -> Verification:
    """Check every file of the results folder ``out`` against its ``manifest.json`` and ``models.json``."""
    out = Path(out)
    found = Verification()
    manifest = _manifest(out, found)
    here = sorted(p.name for p in out.iterdir() if p.is_dir() and FOLDER.match(p.name))
    listed = manifest["provenance"] if manifest else {}
    for name in sorted(set(listed) - set(here)):
        found.add(name, f"{name}/ missing: {MANIFEST} lists this section and its {len(listed[name]['files'])} files")
    for name in here:
        files: dict[str, _File] = {}
        if manifest is not None and name not in listed:
            if (out / name / "error.txt").is_file() and not (out / name / "report.json").exists():
                continue  # a section that did not run (its error): no page lists it, the currency line says so
            found.add(name, f"{name}/ unknown: {MANIFEST} lists no such section")
        for relative, digest in listed.get(name, {}).get("files", {}).items():
            files.setdefault(relative, _File()).listed[MANIFEST] = str(digest)
        _models(out / name, files, found)
        if manifest is not None:
            for path in sorted((out / name).rglob("*")):
                relative = path.relative_to(out).as_posix()
                if path.is_file() and relative not in files:
                    files[relative] = _File(unknown=True)
        _hash(out, files)
        for relative, record in sorted(files.items()):
            if (problem := record.problem()) is not None:
                found.add(name, f"{relative} {problem}")
    if manifest is not None:
        _page(out, manifest["files"], set(here), found)
    return found


def _page(out: Path, listed: dict[str, str], sections: set[str], found: Verification) -> None:
    """The page's own files (``index.md`` is ``results.md`` in an output folder); in a page folder, no other."""
    page_folder = (out / PAGE).is_file() or not (out / RENDERED).is_file()
    files: dict[str, _File] = {}
    for name, digest in listed.items():
        shown = name if page_folder or name != PAGE else RENDERED
        files.setdefault(shown, _File()).listed[MANIFEST] = str(digest)
    if page_folder:
        for path in sorted(out.iterdir()):
            if path.is_dir() and path.name not in sections:
                found.add(PAGE_FILES, f"{path.name}/ unknown: a folder that is no section")
            elif path.is_file() and path.name not in files and path.name != MANIFEST:
                files[path.name] = _File(unknown=True)
    _hash(out, files)
    for name, record in sorted(files.items()):
        if (problem := record.problem()) is not None:
            found.add(PAGE_FILES, f"{name} {problem}")
