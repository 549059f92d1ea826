"""Provenance of reproduced results: the code version, package versions, data files and training runs.

``reproduce`` records, per environment, the code version and the data files its env declares
(``report.json``) and one row per training run (``runs.csv``); the results page gathers them into
``manifest.json``. No machine path is recorded: data files by their path inside a data folder.
"""

from __future__ import annotations

import json
from typing import Any

import pandas as pd

from gym4real.bench.versions import NOT_RECORDED
from gym4real.rl.imported import imported_distributions, union
from gym4real.rl.schedules import learning_rate_words
from gym4real.rl.train import TrainingRun, started_by

#: Columns of ``runs.csv`` read as text: a commit such as ``266e395`` would otherwise be read as a number.
RUNS_TEXT = {"trained_by": str}

def imported(runs: list[TrainingRun]) -> dict[str, str]:
    """The distributions this process and the ``runs`` (their ``run.json``, where recorded) imported.

    Called at the end of a section's test phase, which loads every model the runs trained; a run trained
    in another process (``--jobs``, Ray) adds what it recorded at its end.
    """
    records = [imported_distributions()]
    for run in runs:
        record = json.loads((run.model_path.parent / "run.json").read_text())
        records.append(record.get("imported", {}))
    return union(*records)


def data_files(env_id: str) -> list[dict[str, Any]]:
    """The data files ``env_id`` declares: name, path in a data folder, SHA-256 (of the copy found, if any).

    Every file an env reads is checked against its registered SHA-256 when it is resolved, so the hash of
    a file read is the registered one; a file not found here says so (``found: no``). A missing file that
    its domain's stand-in replaces (``gym4real data synthesize``) names the stand-in found in its place,
    with the SHA-256 of that copy (``read_instead``): the file a preset that trains on it reads.
    """
    from gym4real.core.datasets import dataset, find, find_stand_in, sha256_of, stand_in_replacing
    from gym4real.core.registry import registry

    rows: list[dict[str, Any]] = []
    for name in registry().envs[env_id].datasets:
        spec, copy = dataset(name), find(name)
        row: dict[str, Any] = {
            "name": name,
            "path": spec.path,
            "sha256": sha256_of(copy.path) if copy else spec.sha256,
            "found": copy.where if copy else "no",
        }
        module = stand_in_replacing(name) if copy is None else None
        if module is not None and (stand_in := find_stand_in(module.PATH)) is not None:
            row["read_instead"] = {"path": module.PATH, "sha256": sha256_of(stand_in.path), "found": stand_in.where}
        rows.append(row)
    return rows


def selected_checkpoint(curve: pd.DataFrame, min_improvement: float = 0.0) -> tuple[int, float] | None:
    """The validation row a run kept its model from: ``(progress, mean return)``, None without validation.

    A run keeps the model of an evaluation whose mean return beats the best so far by more than
    ``min_improvement`` (SB3 runs: by any amount), so the kept one is the last such evaluation.
    """
    unit = "episodes" if "episodes" in curve.columns else "timesteps"
    best, kept = float("-inf"), None
    for progress, mean in zip(curve[unit], curve["mean_return"], strict=True):
        if mean > best + min_improvement:
            best, kept = float(mean), (int(progress), float(mean))
    return kept


def runs_table(runs: list[TrainingRun]) -> pd.DataFrame:
    """``runs.csv``: one row per training run, its budget, cost, learning rate, kept checkpoint and settings.

    ``trained_by`` is the code version that started the run from scratch (``git describe --dirty``; for a
    run recorded before starts were, the one that finished it) and ``started_on`` the CPU model of the
    machine that started it (``not recorded`` for those runs); ``cpu`` the CPU model of the machine that
    finished it; ``resumes`` lists the checkpoints it went on from (JSON: unit, count, code version, CPU
    model), ``[]`` for a run never interrupted.
    """
    rows = []
    for run in sorted(runs, key=lambda r: (r.algo, r.seed)):
        settings = json.loads((run.model_path.parent / "settings.json").read_text())
        record = json.loads((run.model_path.parent / "run.json").read_text())
        hp = settings["hyperparameters"]
        curve = pd.read_csv(run.curve_csv) if run.curve_csv.exists() else pd.DataFrame()
        kept = selected_checkpoint(curve, float(hp.get("min_improvement", 0.0))) if len(curve) else None
        rows.append(
            {
                "algo": run.agent,
                "seed": run.seed,
                "preset": run.preset,
                "total_timesteps": hp.get("total_timesteps"),
                "episodes": hp.get("episodes"),
                "env_steps": run.env_steps,
                "eval_steps": run.eval_steps,
                "wall_s": run.wall_time_s,
                "env_steps_per_s": run.steps_per_s,
                "learning_rate": learning_rate_words(hp),
                "selected_unit": "episodes" if "episodes" in curve.columns else "timesteps",
                "selected_at": kept[0] if kept else None,
                "selected_validation_return": kept[1] if kept else None,
                "settings": json.dumps(hp, sort_keys=True),
                "trained_by": started_by(record),
                "started_on": record["started"]["cpu"] if "started" in record else NOT_RECORDED,
                "cpu": record.get("cpu", NOT_RECORDED),
                "resumes": json.dumps(record["resumes"]) if "resumes" in record else "not recorded",
            }
        )
    return pd.DataFrame(rows)
