"""Measure the non-causal upper references of published results sections and add them to their episodes.

``python scripts/add_upper_references.py [SECTION ...]`` (default: every section of ``docs/results``) runs, for
each paper section whose protocol is current (the section's recorded protocol fingerprint equals the
installed one, and no data file it read differs from the copy here), the env's upper references
(``hindsight``, ``oracle``: :func:`gym4real.core.registry.non_causal`) on the test protocol, and writes
their rows into the section's ``episodes.csv`` beside the rows ``gym4real reproduce`` wrote (the rows of the
trained agents and the baselines are kept as they are, byte for byte). ``report.json`` gains
``upper_references``: the policies, the code version that measured them, the command and its test wall time;
the section's statistics, claims and figures are then recomputed from ``episodes.csv``
(:func:`gym4real.results.analysis.analyse`). Render the page afterwards (``write_page``).

Sections that ``gym4real reproduce`` made after the upper references existed hold them already (it runs them
with the baselines); this adds them to sections published before, without training anything again.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from gym4real.bench.benchmark import benchmark
from gym4real.bench.versions import code_version
from gym4real.core.registry import non_causal
from gym4real.results import analysis
from gym4real.results.fingerprints import NOT_FOUND, section_changes
from gym4real.results.reproduce import episodes_table


def _blocking(changes: list[str]) -> list[str]:
    """The changes that make a section's test episodes incomparable: any but a training file not found here."""
    return [c for c in changes if not (c.startswith(("data.", "trainer.")) and c.endswith(NOT_FOUND))]


def add(folder: Path, version: str | None = None) -> str:
    """Add the upper references to one section; return what was done (or why not).

    ``version``: the code version that measures them (default :func:`code_version`; a run over several sections
    reads it once, before it writes into the first).
    """
    report_path = folder / "report.json"
    report = json.loads(report_path.read_text())
    env_id, budget = report["env_id"], report["budget"]
    upper = non_causal(env_id)
    if not upper:
        return f"{folder.name}: no upper reference registered for {env_id}"
    blocking = _blocking(section_changes(folder))
    if blocking:
        return f"{folder.name}: not current ({'; '.join(blocking)}): rerun it with `gym4real reproduce --stale`"
    start = time.perf_counter()
    result = benchmark(env_id, upper, episodes="test")
    wall = time.perf_counter() - start
    episodes = pd.read_csv(folder / "episodes.csv")
    added = episodes_table(result, upper, [])
    kept = episodes[~episodes["policy"].isin(upper)]
    merged = pd.concat([kept, added[[c for c in added.columns if c in episodes.columns]]], ignore_index=True)
    merged["seed"] = merged["seed"].astype("Int64")
    merged.to_csv(folder / "episodes.csv", index=False)
    report["upper_references"] = {
        "policies": upper,
        "code_version": version or code_version(),
        "command": f"python scripts/add_upper_references.py {folder.as_posix()}",
        "test_wall_time_s": wall,
    }
    report_path.write_text(json.dumps(report, indent=1))
    analysis.analyse(folder, env_id, budget)
    return f"{folder.name}: added {', '.join(upper)} ({len(added)} test episodes, {wall:.0f} s)"


def main(argv: Sequence[str] | None = None) -> int:
    """Add the upper references; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="*", type=Path, help="section folders (default: docs/results/*-paper)")
    args = parser.parse_args(argv)
    sections = args.sections or sorted(p.parent for p in Path("docs/results").glob("*-paper/report.json"))
    version = code_version()  # before anything is written: the checkout's commit, not "dirty" with our output
    for folder in sections:
        print(add(folder, version), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
