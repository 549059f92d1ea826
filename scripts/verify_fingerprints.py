"""Record the fingerprints of a results section trained before sections recorded them, where verified.

A section written before ``report.json`` held fingerprints (:mod:`gym4real.results.fingerprints`) gets
each one only when this checkout verifies that it is the one its numbers were made with:

- ``protocol``: every baseline is run again on the installed test protocol and must score, episode by
  episode, what ``episodes.csv`` records for it (to 1e-12 relative; the CSV round-trips floats);
- ``data``: the SHA-256 of each data file as the section's report recorded it at run time (a stand-in read
  in place of a missing file: the stand-in's recorded hash); a file that differs here makes it stale;
- ``trainer``: each run's settings (``runs.csv``) must be the installed preset's, the recorded
  Stable-Baselines3 and PyTorch versions the installed ones, and ``--trainer-verified`` must say how
  :data:`~gym4real.results.fingerprints.TRAINER_VERSION` was checked against the training commit (the golden
  smoke runs of ``tests/test_trainer_version.py`` giving the same hashes there as here).

A part that fails its check is not recorded (the section then shows as stale and names it). How each part
was verified is written beside the fingerprints (``fingerprints_verified``).

Usage: ``python scripts/verify_fingerprints.py docs/results/dam-v0-paper [...] --trainer-verified TEXT``
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from gym4real.bench import versions
from gym4real.bench.benchmark import benchmark, protocol
from gym4real.results import fingerprints
from gym4real.rl.presets import load_preset


def code_words(version: str | None) -> str:
    """A code version for a sentence: ``ba1df74-dirty`` is ``ba1df74 with uncommitted changes``."""
    text = str(version)
    return f"{text.removesuffix('-dirty')} with uncommitted changes" if text.endswith("-dirty") else text


def data_words(recorded: dict[str, str], differ: list[str]) -> str:
    """How the data fingerprint compares here, in words (an env that reads no data file says so)."""
    if not recorded:
        return "the env reads no data file, so there is none to compare"
    return f"the SHA-256 of the {len(recorded)} data files read, as report.json recorded them at run time" + (
        f"; differ from the copies found here: {', '.join(differ)}" if differ else "; equal to the copies found"
    )


def verify_protocol(env_id: str, episodes: pd.DataFrame) -> str | None:
    """How the baselines' rerun matched ``episodes.csv``, or None when one episode differs."""
    baselines = list(protocol(env_id).policies)
    result = benchmark(env_id, baselines, episodes="test")
    worst = 0.0
    for name in baselines:
        mine = np.asarray(result.objective_values(name), dtype=float)
        theirs = episodes.loc[episodes["policy"] == name].sort_values("episode")["objective"].to_numpy(float)
        if mine.shape != theirs.shape or not np.allclose(mine, theirs, rtol=1e-12, atol=0.0):
            gap = np.max(np.abs(mine - theirs)) if mine.shape == theirs.shape else "another number of episodes"
            print(f"  protocol: `{name}` differs ({gap})")
            return None
        worst = max(worst, float(np.max(np.abs(mine - theirs))) if mine.size else 0.0)
    count = int(sum(episodes["policy"].isin(baselines)))
    rerun_by = code_words(versions.code_version())
    return (
        f"the {len(baselines)} baselines ({', '.join(baselines)}) rerun by {rerun_by} on the "
        f"installed protocol score the {count} baseline rows of episodes.csv (largest difference {worst:.3g})"
    )


def verify_data(report: dict[str, Any], installed: dict[str, str]) -> tuple[dict[str, str], str]:
    """The data fingerprint the run recorded (its files' SHA-256 at run time), and how it compares here."""
    recorded = fingerprints.data_fingerprint(report["data_files"])
    differ = sorted(k for k in recorded if recorded.get(k) != installed.get(k))
    if differ:
        print(f"  data: differs in {differ}")
    return recorded, data_words(recorded, differ)


def verify_trainer(report: dict[str, Any], runs: pd.DataFrame, how: str) -> tuple[dict[str, Any] | None, str]:
    """The trainer fingerprint and how it was verified, or ``(None, "")`` when a run or version differs."""
    env_id = report["env_id"]
    for row in runs.to_dict("records"):
        if json.loads(row["settings"]) != load_preset(env_id, row["algo"], row["preset"]):
            print(f"  trainer: {row['algo']} seed {row['seed']} trained other settings than `{row['preset']}`")
            return None, ""
    recorded = fingerprints.trainer_fingerprint(env_id, report["presets"])
    for dist in ("stable-baselines3", "torch"):
        if dist in recorded and report["versions"].get(dist) != recorded[dist]:
            print(f"  trainer: {dist} {report['versions'].get(dist)} recorded, {recorded[dist]} installed")
            return None, ""
    return recorded, (
        f"every run's settings (runs.csv) equal the installed presets; SB3/PyTorch versions as recorded; {how}"
    )


def main() -> None:
    """Verify and record the fingerprints of each section named on the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="+", type=Path)
    parser.add_argument("--trainer-verified", required=True, help="how TRAINER_VERSION was checked when trained")
    args = parser.parse_args()
    for folder in args.sections:
        report_path = folder / "report.json"
        report = json.loads(report_path.read_text())
        env_id = report["env_id"]
        print(f"{folder.name}:")
        installed = fingerprints.fingerprints(env_id, report["budget"])
        found: dict[str, Any] = {}
        how: dict[str, str] = {}
        episodes = pd.read_csv(folder / "episodes.csv")
        if (text := verify_protocol(env_id, episodes)) is not None:
            found["protocol"], how["protocol"] = installed["protocol"], text
        found["data"], how["data"] = verify_data(report, installed["data"])
        trainer, text = verify_trainer(report, pd.read_csv(folder / "runs.csv"), args.trainer_verified)
        if trainer is not None:
            found["trainer"], how["trainer"] = trainer, text
        report[fingerprints.KEY] = found
        report["fingerprints_verified"] = how
        report_path.write_text(json.dumps(report, indent=1))
        print(f"  recorded: {sorted(found)}")


if __name__ == "__main__":
    main()
