"""The trained models of a results section, published beside its test episodes.

Each training run's model (SB3: ``model.zip`` and, when the preset normalises observations, the statistics
``normalize.npz`` it was tested with) is copied into ``<env>-<budget>/models/<algo>-seed<S>/`` when its files
total at most :data:`MAX_BYTES`. A trained file that holds more than a test episode reads is published as a
smaller one that acts the same, the trained file's SHA-256 listed beside it (:data:`SLIMMED`): a tabular
run's ``qtable.npz`` as its greedy policy (:func:`gym4real.rl.tabular.save_greedy_table`: the action of every
state, at a few percent of the table's size), an SB3 ``model.zip`` without its optimizer's state
(:func:`gym4real.rl.model_file.save_without_optimizer_state`: about a third of a PPO file, half of a DQN
one), so that ``gym4real evaluate`` on it reruns that seed's test episodes. ``models.json`` lists every
model, published or not, with the SHA-256 and size of each file, the ``gym4real evaluate`` command that tests
a published one and the ``gym4real train`` command that trains it again. A model over :data:`MAX_BYTES`
(picking-v1's CNNs) is listed by the SHA-256 of the copy it would be published as; that copy depends on the
trained file alone, not on when it is written, so a copy uploaded elsewhere later can be checked against it.
``gym4real evaluate`` and ``bench`` refuse a published model whose files differ from the listed SHA-256
(:mod:`gym4real.bench.published`).

A model's ``note`` says, where it was measured, how ``gym4real evaluate`` on it agrees with its seed's rows
of ``episodes.csv`` on which machines ("bit for bit" only where every episode and column is equal);
``agreement`` states the agreement to expect anywhere: ``rtol``, the largest relative difference per test
episode and column (objective, return and each component). A model without ``agreement`` reproduces its
rows bit for bit.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gym4real.bench.published import FOLDER, LISTING
from gym4real.bench.seeds import listed_seeds_flag
from gym4real.core.datasets import sha256_of
from gym4real.core.registry import slug
from gym4real.rl.model_file import save_without_optimizer_state
from gym4real.rl.tabular import QTABLE, save_greedy_table
from gym4real.rl.train import TrainingRun, started_by

#: The largest model (all its files) published beside the results.
MAX_BYTES = 5 * 1024 * 1024
#: Files beside a model that a policy loads with it.
COMPANIONS = ("normalize.npz",)
#: A trained model file published as a smaller one that acts the same: the function that writes it from the
#: trained one, the ``models.json`` key that lists the trained file's hash, and what the published one keeps.
SLIMMED: dict[str, tuple[Callable[[Path, Path], None], str, str]] = {
    QTABLE: (save_greedy_table, "trained_table", "its greedy policy (the action of each state; values not kept)"),
    "model.zip": (
        save_without_optimizer_state,
        "trained_model",
        "without its optimizer's state (Adam's moments, which acting never reads)",
    ),
}


def model_files(run: TrainingRun) -> list[Path]:
    """The files that make up a run's model: the model and its companions found beside it."""
    return [run.model_path] + [p for name in COMPANIONS if (p := run.model_path.with_name(name)).exists()]


def _publish_file(source: Path, path: Path) -> Path:
    """Write the published copy of a model file and return its path.

    A Q-table is published as its greedy policy, an SB3 model without its optimizer's state (see
    :data:`SLIMMED`); other files are copied.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    if source.name in SLIMMED:
        SLIMMED[source.name][0](source, path)
    else:
        shutil.copy(source, path)
    return path


def publish_models(runs: list[TrainingRun], section: Path, budget: str) -> list[dict[str, Any]]:
    """Copy each run's model into ``section/models/`` (up to :data:`MAX_BYTES`) and write ``models.json``.

    Args:
        runs: The section's training runs.
        section: The results folder ``<env>-<budget>``; its previous ``models/`` is replaced.
        budget: The section's budget (for the commands).

    Returns:
        The listing written to ``models.json``: per run, its files (name, SHA-256, bytes), whether it is
        published and where, and the commands that evaluate and retrain it.
    """
    target = section / FOLDER
    shutil.rmtree(target, ignore_errors=True)
    listing = []
    for run in sorted(runs, key=lambda r: (r.agent, r.seed)):
        name = f"{run.agent}-seed{run.seed}"
        files = [_publish_file(p, target / name / p.name) for p in model_files(run)]
        size = sum(p.stat().st_size for p in files)
        trainer = "" if run.trainer == "sb3" else f" --trainer {run.trainer}"
        published = size <= MAX_BYTES
        record = json.loads((run.model_path.parent / "run.json").read_text())
        entry: dict[str, Any] = {
            "algo": run.algo,
            **({} if run.trainer == "sb3" else {"trainer": run.trainer}),
            "seed": run.seed,
            "preset": run.preset,
            "trained_by": started_by(record),
            "files": [{"name": p.name, "sha256": sha256_of(p), "bytes": p.stat().st_size} for p in files],
            "bytes": size,
            "published": published,
            "retrain": (
                f"gym4real train {run.env_id} --algo {run.algo}{trainer} --preset {run.preset} --seed {run.seed} "
                f"--out runs/{slug(run.env_id)}/{budget}/{run.agent}/seed{run.seed}"
            ),
        }
        if run.model_path.name in SLIMMED:
            _, key, published_as = SLIMMED[run.model_path.name]
            entry[key] = {
                "name": run.model_path.name,
                "sha256": sha256_of(run.model_path),
                "bytes": run.model_path.stat().st_size,
                "published_as": published_as,
            }
        if published:
            path = f"{section.name}/{FOLDER}/{name}/{run.model_path.name}"
            entry["path"] = f"{FOLDER}/{name}/{run.model_path.name}"
            entry["evaluate"] = (
                f"gym4real evaluate published-{run.agent}={run.agent}:{path} --envs {run.env_id} "
                f"--seeds {listed_seeds_flag([run.seed])} (in the page folder)"
            )
        else:
            shutil.rmtree(target / name)
            entry["why_not_published"] = f"{size / 2**20:.1f} MiB, over the {MAX_BYTES // 2**20} MiB limit"
        listing.append(entry)
    (section / LISTING).write_text(json.dumps(listing, indent=1) + "\n")
    return listing


def list_unkept_models(section: Path, why: str) -> list[dict[str, Any]]:
    """Write ``models.json`` for a section whose models were not kept (trained before models were published).

    Each run of its ``runs.csv`` is listed unpublished, with ``why`` and the ``gym4real train`` command that
    trains it again; no hash is recorded, since no copy of the model is left to hash.
    """
    import pandas as pd

    report = json.loads((section / "report.json").read_text())
    runs = pd.read_csv(section / "runs.csv")
    listing = [
        {
            "algo": row["algo"],
            "seed": int(row["seed"]),
            "preset": row["preset"],
            "files": "not recorded",
            "published": False,
            "why_not_published": why,
            "retrain": (
                f"gym4real train {report['env_id']} --algo {row['algo']} --preset {row['preset']} "
                f"--seed {int(row['seed'])} --out runs/{slug(report['env_id'])}/{report['budget']}/{row['algo']}/"
                f"seed{int(row['seed'])}"
            ),
        }
        for row in runs.sort_values(["algo", "seed"]).to_dict("records")
    ]
    (section / LISTING).write_text(json.dumps(listing, indent=1) + "\n")
    return listing
