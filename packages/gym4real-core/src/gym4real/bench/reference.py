"""Reference runs: the paper agents' and baselines' per-episode test scores, shipped with each domain.

A domain distribution ships, for an environment ``gym4real/<name>``, two package-data files:

- ``gym4real/<domain>/reference/<name>.csv``: one row per policy, training seed and test episode, with
  the columns ``policy, seed, episode, objective, return`` and the reward components; ``seed`` is empty
  for a baseline (a rule-based policy has no training seed);
- ``gym4real/<domain>/reference/<name>.json``: the budget, the manifest of the run that measured them,
  and the fingerprint of the protocol they were measured on (:func:`fingerprint`: the environment's
  distribution and version, fidelity, ``make()`` arguments, test episodes and objective).

:func:`export_reference` writes them from a results folder of ``gym4real reproduce``
(``<name>-<budget>/episodes.csv`` and the provenance in ``report.json``; ``scripts/export_references.py``);
:func:`load_reference` reads them, and :func:`check_fingerprint` refuses reference runs measured on
another protocol than the installed environment's, naming each difference. :func:`published_lines` shows the
paper agents' and the upper references' scores beside what ``gym4real bench`` ran.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd

from gym4real.bench import stats
from gym4real.bench.benchmark import protocol
from gym4real.bench.episodes import score_matrices
from gym4real.bench.numbers import human, human_interval
from gym4real.bench.upper_label import label
from gym4real.core.errors import ConfigError, ReferenceMismatchError
from gym4real.core.registry import MARK, env_spec, load_object, non_causal, registry, slug

#: Folder of the reference files inside a domain package.
FOLDER = "reference"
#: The provenance of a results section (its ``report.json``) that a reference file keeps as its manifest.
MANIFEST_FIELDS = ("command", "code_version", "versions", "platform", "data_files")
#: Fingerprint fields, in the order differences are named.
FINGERPRINT_FIELDS = (
    "env_id",
    "distribution",
    "version",
    "fidelity",
    "env_kwargs",
    "episodes",
    "episodes_sha256",
    "objective",
    "policy_forward",
)


@dataclass(frozen=True)
class Reference:
    """The reference runs of one environment.

    Attributes:
        env_id: The environment.
        scores: Policy -> per-episode objective, ``(seeds, episodes)`` (one row for a baseline).
        seeds: Policy -> its training seeds (empty for a baseline).
        fingerprint: The protocol the scores were measured on (:func:`fingerprint`).
        budget: The ``gym4real reproduce`` budget of the runs (``paper``).
        manifest: The manifest of the run that measured them.
        source: Where the files were read from (shipped ones: the domain package and the file).
    """

    env_id: str
    scores: dict[str, np.ndarray]
    seeds: dict[str, list[int]]
    fingerprint: dict[str, Any]
    budget: str = "paper"
    manifest: dict[str, Any] = field(default_factory=dict)
    source: str = ""

    @property
    def agents(self) -> list[str]:
        """The trained agents (policies with training seeds)."""
        return [name for name, seeds in self.seeds.items() if seeds]


def fingerprint(env_id: str, env: gym.Env[Any, Any]) -> dict[str, Any]:
    """The protocol an environment's test scores are measured on, as installed.

    Args:
        env_id: A registered id with an evaluation protocol.
        env: The environment made with the protocol's ``make()`` arguments (its config gives the fidelity).
    """
    spec = protocol(env_id)
    kwargs = json.loads(json.dumps(dict(spec.env_kwargs), default=str))
    episodes = load_object(spec.protocol)(dict(spec.env_kwargs))
    listing = json.dumps([{"seed": e.get("seed"), "options": e.get("options")} for e in episodes], default=str)
    dist, version = registry().distributions.get(registry().owners.get(env_id, ""), ("?", "?"))
    found = {
        "env_id": env_id,
        "distribution": dist,
        "version": version,
        "fidelity": getattr(getattr(env.unwrapped, "config", None), "fidelity", None),
        "env_kwargs": kwargs,
        "episodes": len(episodes),
        "episodes_sha256": hashlib.sha256(listing.encode()).hexdigest(),
        "objective": list(spec.objective) or ["return"],
    }
    if spec.portable_forward:  # named only where set: the other protocols' fingerprints stay as recorded
        found["policy_forward"] = "portable"
    return found


def installed_fingerprint(env_id: str) -> dict[str, Any]:
    """The fingerprint of ``env_id``'s test protocol as installed (:func:`fingerprint` of an env made for it)."""
    env = gym.make(env_id, **protocol(env_id).env_kwargs)
    try:
        return fingerprint(env_id, env)
    finally:
        env.close()


def check_fingerprint(reference: Reference, installed: dict[str, Any]) -> None:
    """Refuse reference runs measured on another protocol than ``installed``'s.

    Raises:
        ReferenceMismatchError: Naming each field that differs, with both values.
    """
    differences = [
        f"{key}: {reference.fingerprint.get(key)!r} in the reference, {installed.get(key)!r} installed"
        for key in FINGERPRINT_FIELDS
        if reference.fingerprint.get(key) != installed.get(key)
    ]
    if differences:
        raise ReferenceMismatchError(
            f"the reference runs of `{reference.env_id}` ({reference.source}) were measured on another protocol "
            f"than the installed environment's ({'; '.join(differences)}): install the version they were measured "
            "on, or compare with reference runs of this version (`--references DIR`, written by "
            "`scripts/export_references.py` from `gym4real reproduce` results)"
        )


def domain_package(env_id: str) -> str:
    """The package of an environment's domain (``gym4real.dam``), where its reference files live."""
    return ".".join(env_spec(env_id).entry_point.split(":")[0].split(".")[:2])


def _folder(env_id: str, folder: str | Path | None) -> Traversable:
    return Path(folder) if folder is not None else resources.files(domain_package(env_id)) / FOLDER


def reference_table(env_id: str, folder: str | Path | None = None) -> Traversable:
    """The reference table of ``env_id`` (``<name>.csv``): in ``folder``, else the one its domain ships."""
    return _folder(env_id, folder) / f"{slug(env_id)}.csv"


def load_reference(env_id: str, folder: str | Path | None = None) -> Reference | None:
    """The reference runs of ``env_id``, from its domain package or from ``folder``; None when there are none.

    Args:
        env_id: A registered id.
        folder: A folder holding ``<name>.csv`` and ``<name>.json`` (default: the domain's ``reference/``).
    """
    try:
        base = _folder(env_id, folder)
    except TypeError:  # the env's module lies in no package (a plugin's single module): it ships no reference runs
        return None
    table, record = base / f"{slug(env_id)}.csv", base / f"{slug(env_id)}.json"
    if not table.is_file():
        return None
    if not record.is_file():
        raise ConfigError(f"`{table}` has no `{record.name}` beside it (the fingerprint of its protocol)")
    with table.open() as handle:
        scores, seeds = score_matrices(pd.read_csv(handle), str(table))
    meta = json.loads(record.read_text())
    return Reference(
        env_id,
        scores,
        seeds,
        meta["fingerprint"],
        meta.get("budget", "paper"),
        meta.get("manifest", {}),
        str(table) if folder is not None else f"{domain_package(env_id)}: {FOLDER}/{table.name}",  # no local path
    )


def export_reference(env_id: str, results: str | Path, budget: str = "paper", into: str | Path | None = None) -> Path:
    """Write the reference files of ``env_id`` from a results folder of ``gym4real reproduce``.

    Reads ``results/<name>-<budget>/episodes.csv`` (and the provenance of ``report.json`` beside it: code
    version, package versions, platform, data files and their SHA-256), checks the table, takes the
    fingerprint of the installed environment (whose test episodes the table must have), and writes
    ``<name>.csv`` and ``<name>.json`` into ``into`` (default: the domain package's ``reference/`` folder, the
    source tree in an editable checkout). Returns the CSV's path.

    Raises:
        ConfigError: No such table, a malformed one, or one with another number of test episodes.
    """
    folder = Path(results) / f"{slug(env_id)}-{budget}"
    table = folder / "episodes.csv"
    if not table.is_file():
        raise ConfigError(f"no `{table}`: run `gym4real reproduce {env_id} --budget {budget}` into `{results}` first")
    frame = pd.read_csv(table)
    scores, _ = score_matrices(frame, str(table))
    installed = installed_fingerprint(env_id)
    found = {m.shape[1] for m in scores.values()}
    if found != {installed["episodes"]}:
        raise ConfigError(
            f"`{table}` has {sorted(found)} test episodes per seed; the installed protocol of `{env_id}` has "
            f"{installed['episodes']}: rerun `gym4real reproduce` with this version"
        )
    report_path = folder / "report.json"
    report = json.loads(report_path.read_text()) if report_path.is_file() else {}
    manifest = {k: report[k] for k in MANIFEST_FIELDS if k in report}
    target = Path(into) if into is not None else Path(str(resources.files(domain_package(env_id)))) / FOLDER
    target.mkdir(parents=True, exist_ok=True)
    written = target / f"{slug(env_id)}.csv"
    frame.to_csv(written, index=False)
    record = {"env_id": env_id, "budget": budget, "fingerprint": installed, "manifest": manifest}
    (target / f"{slug(env_id)}.json").write_text(json.dumps(record, indent=1) + "\n")
    return written


def published_lines(env_id: str) -> list[str]:
    """The paper agents' and non-causal upper references' scores in the reference runs the env's domain ships.

    The lines ``gym4real bench`` prints under its table of the test protocol: the reference runs are the
    committed results (``docs/results/<name>-paper``, exported by :func:`export_reference`), not run here.
    Each row: the IQM of the per-episode objective (a paper agent's training seeds pooled) with its 95 %
    bootstrap interval, as the results page computes them (:func:`~gym4real.bench.stats.iqm_ci`); an upper
    reference under its label with its kind (:func:`~gym4real.bench.upper_label.label`), not ranked.
    Empty when the domain ships no reference runs (or they hold neither); one line saying why when they were
    measured on another protocol than the installed one.
    """
    reference = load_reference(env_id)
    if reference is None:
        return []
    installed = installed_fingerprint(env_id)
    try:
        check_fingerprint(reference, installed)
    except ReferenceMismatchError as exc:
        return [f"The paper's agents are not shown: {exc}"]
    upper = [p for p in non_causal(env_id) if p in reference.scores]
    rows = []
    for policy in [*reference.agents, *upper]:
        trained = policy in reference.agents
        iqm, low, high = stats.iqm_ci(reference.scores[policy], trained)
        rows.append(
            (
                policy if trained else label(env_id, policy),
                "paper agent" if trained else "upper reference, not ranked",
                str(len(reference.seeds[policy])) if trained else "-",
                f"{human(iqm)} {human_interval(low, high)}",
            )
        )
    if not rows:
        return []
    made = reference.manifest.get("code_version", "?")
    head = ("policy", "kind", "seeds", "objective IQM [95 % interval]")
    widths = [max(len(row[i]) for row in [head, *rows]) for i in range(3)]
    return [
        f"The paper's agents and the {MARK} on this protocol, from the committed results",
        f"(not run here: the reference runs of {reference.source}, budget `{reference.budget}`, code {made}):",
        *(
            f"  {name:{widths[0]}s}  {kind:{widths[1]}s}  {seeds:>{widths[2]}s}  {score}"
            for name, kind, seeds, score in [head, *rows]
        ),
    ]
