"""Whether a results section is current: the fingerprints of what its numbers depend on.

A section's test scores depend on three things, each with a fingerprint that is the same on every machine
and that changes only when the scores would change:

- ``protocol``: the environment's test protocol (:func:`gym4real.bench.reference.fingerprint`: its
  distribution and version, fidelity, ``make()`` arguments, test episodes and objective);
- ``data``: the SHA-256 of each data file the environment reads (of the stand-in read in its place, where
  a file was missing);
- ``trainer``: :data:`TRAINER_VERSION` (the version of our training code's output, pinned by the golden
  smoke runs of ``tests/test_trainer_version.py``), the SHA-256 of each algorithm's preset settings,
  and the versions of Stable-Baselines3 and PyTorch when an algorithm trains with them. A section of the
  JAX trainer's runs (``<env>-<budget>-jax``) says so: ``trainer: jax``, :data:`JAX_TRAINER_VERSION`
  (pinned by the guard run of ``tests/test_jax_trainer_version.py``), its PPO preset's settings and the
  versions of jax, jaxlib, optax and numba (a section of the reference trainer names none, as its
  fingerprints always did).

A section whose recorded fingerprints (``report.json``) equal those of the installed code is **current**,
whatever commit trained it; otherwise it is **stale**, and :func:`changes` names what changed. Claims are
always decided by the installed rules from ``episodes.csv``, so they need no fingerprint. A change of the
protocol or data makes a section's test phase stale (and, for data, its training); a change of the trainer
makes its training stale.
"""

from __future__ import annotations

import hashlib
import json
from importlib import metadata
from pathlib import Path
from typing import Any

from gym4real.core.errors import Gym4RealError

#: The version of our training code's output (SB3 and tabular trainers, schedules, model selection). Raise
#: it, and the golden values of ``tests/test_trainer_version.py``, when a change of the training code
#: changes what a seeded run trains; a change that moves code without changing its output keeps it.
TRAINER_VERSION = 1
#: The version of the JAX PPO trainer's output (:mod:`gym4real.rl.jax_ppo`); raise it, and record the golden
#: file of ``tests/test_jax_trainer_version.py`` (``python scripts/jax_trainer_golden.py --record``), when a
#: change of that code changes what a seeded run trains.
JAX_TRAINER_VERSION = 1
#: The distributions whose versions the JAX trainer's fingerprint records.
JAX_DISTRIBUTIONS = ("jax", "jaxlib", "optax", "numba")
#: The algorithms trained with Stable-Baselines3 and PyTorch (their versions are part of the fingerprint).
SB3_ALGOS = ("ppo", "dqn")
#: The key of the fingerprints in a section's ``report.json``.
KEY = "fingerprints"
#: The parts of the fingerprints, in the order changes are named.
PARTS = ("protocol", "data", "trainer")


def _sha256_json(value: Any) -> str:
    return hashlib.sha256(json.dumps(value, sort_keys=True, default=str).encode()).hexdigest()


def protocol_fingerprint(env_id: str) -> dict[str, Any]:
    """The installed test protocol of ``env_id`` (:func:`gym4real.bench.reference.installed_fingerprint`)."""
    from gym4real.bench.reference import installed_fingerprint

    return installed_fingerprint(env_id)


#: The data fingerprint of a file found nowhere here (nor a stand-in in its place): no copy to hash.
NOT_FOUND = "not found here"


def data_fingerprint(data_files: list[dict[str, Any]]) -> dict[str, str]:
    """Data file name -> the SHA-256 of the copy read (``provenance.data_files`` rows; a stand-in's if read).

    A file with no copy here is :data:`NOT_FOUND`, not its registered hash: nothing was read to hash.
    """
    found = {}
    for row in data_files:
        instead = row.get("read_instead")
        if instead:
            found[row["name"]] = instead["sha256"]
        else:
            found[row["name"]] = NOT_FOUND if row.get("found") == "no" else row["sha256"]
    return dict(sorted(found.items()))


def _installed(dists: tuple[str, ...]) -> dict[str, str]:
    found = {}
    for dist in dists:
        try:
            found[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            found[dist] = "not installed"
    return found


def trainer_fingerprint(env_id: str, presets: dict[str, str], trainer: str = "sb3") -> dict[str, Any]:
    """What a seeded training run of ``env_id``'s ``presets`` (algo -> preset) trains, as installed.

    With ``trainer="jax"``: the budget's PPO preset trained by the JAX trainer (its runs alone, as
    :func:`gym4real.results.plan.plan` plans them).
    """
    from gym4real.rl.presets import load_preset

    if trainer != "sb3":
        presets = {algo: preset for algo, preset in presets.items() if algo == "ppo"}
    found: dict[str, Any] = {
        "trainer_version": TRAINER_VERSION if trainer == "sb3" else JAX_TRAINER_VERSION,
        "presets": {
            algo: {"preset": preset, "settings_sha256": _sha256_json(load_preset(env_id, algo, preset))}
            for algo, preset in sorted(presets.items())
        },
    }
    if trainer != "sb3":
        return {"trainer": trainer, **found, **_installed(JAX_DISTRIBUTIONS)}
    if any(algo in SB3_ALGOS for algo in presets):
        found |= _installed(("stable-baselines3", "torch"))
    return found


def fingerprints(env_id: str, budget: str, trainer: str = "sb3") -> dict[str, Any]:
    """The installed fingerprints of a section of ``env_id`` at ``budget`` (by ``trainer``): protocol, data, trainer."""
    from gym4real.bench.seeds import presets
    from gym4real.results import provenance

    return {
        "protocol": protocol_fingerprint(env_id),
        "data": data_fingerprint(provenance.data_files(env_id)),
        "trainer": trainer_fingerprint(env_id, presets(env_id, budget), trainer),
    }


def _differences(recorded: Any, installed: Any, where: str) -> list[str]:
    """Each leaf that differs, as ``where.key: recorded -> installed`` (long values by their key only)."""
    if isinstance(recorded, dict) and isinstance(installed, dict):
        found = []
        for key in sorted(set(recorded) | set(installed), key=str):
            if key not in installed:
                found.append(f"{where}.{key}: gone")
            elif key not in recorded:
                found.append(f"{where}.{key}: new")
            else:
                found += _differences(recorded[key], installed[key], f"{where}.{key}")
        return found
    if recorded == installed:
        return []
    if installed == NOT_FOUND:
        return [f"{where}: {NOT_FOUND}"]
    short = all(len(json.dumps(v, default=str)) <= 40 for v in (recorded, installed))
    return [f"{where}: {recorded!r} -> {installed!r}" if short else f"{where} changed"]


def changes(recorded: dict[str, Any] | None, installed: dict[str, Any]) -> list[str]:
    """What differs between a section's recorded fingerprints and the installed ones; empty when current."""
    if not recorded:
        return ["no fingerprints recorded"]
    found = []
    for part in PARTS:
        if part not in recorded:
            found.append(f"{part}: not recorded")
        else:
            found += _differences(recorded[part], installed[part], part)
    return found


#: How a change names a section whose fingerprints cannot be computed here (its env cannot be made).
UNAVAILABLE = "cannot be fingerprinted here"


def not_here(found: list[str]) -> tuple[list[str], list[str]]:
    """The changes of :func:`changes` that only say what is missing here, and not what changed.

    Returns:
        The data files found nowhere here (by name), and why the fingerprints cannot be computed here (the
        error, with its fix); the other changes make a section stale.
    """
    suffix = f": {NOT_FOUND}"
    missing = [c[len("data.") : -len(suffix)] for c in found if c.startswith("data.") and c.endswith(suffix)]
    unavailable = [c[len(UNAVAILABLE) + 2 :] for c in found if c.startswith(f"{UNAVAILABLE}: ")]
    return missing, unavailable


def section_changes(folder: Path) -> list[str]:
    """What makes the results section in ``folder`` stale (empty when it is current).

    Raises:
        DamagedResultsError: Its ``report.json`` is not UTF-8 JSON of a section (named).
    """
    from gym4real.results.artefacts import DamagedResultsError, read_json, trainer_of

    if (folder / "error.txt").exists():
        return ["not run (error.txt)"]
    report_path = folder / "report.json"
    if not report_path.exists():
        return ["no report.json"]
    where = f"{folder.name}/report.json"
    report = read_json(report_path, where)
    if not (
        isinstance(report, dict) and isinstance(report.get("env_id"), str) and isinstance(report.get("budget"), str)
    ):
        raise DamagedResultsError(f"`{where}` names no env_id and budget: it is damaged")
    try:
        installed = fingerprints(report["env_id"], report["budget"], trainer_of(folder.name))
    except Gym4RealError as exc:
        return [f"{UNAVAILABLE}: {' '.join(str(exc).split())}"]
    return changes(report.get(KEY), installed)
