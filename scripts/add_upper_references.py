"""Measure baselines on published results sections' test protocols and add them to their episodes.

``python scripts/add_upper_references.py [--policies NAME,...] [SECTION ...]`` (default: the env's upper
references, every section of ``docs/results``) runs, for each paper section whose protocol is current (the
section's recorded protocol fingerprint equals the installed one, and no data file it read differs from the copy
here), the policies on the test protocol and writes their rows into the section's ``episodes.csv`` beside the rows
``gym4real reproduce`` wrote (the rows of the trained agents and the other baselines are kept as they are, byte for
byte; rows of the same policies measured before are replaced in their place).

- Without ``--policies``: the env's upper references (``hindsight``, ``oracle``:
  :func:`gym4real.core.registry.non_causal`); ``report.json`` gains ``upper_references``.
- ``--policies mpc``: any registered baseline of the env (here the causal ``mpc`` of dam, microgrid and wds);
  causal baselines are recorded under ``added_baselines``, upper references under ``upper_references``.

Each record holds the policies, the code version that measured them, the command and its test wall time. The
section's statistics, claims and figures are then recomputed from ``episodes.csv``
(:func:`gym4real.results.analysis.analyse`). Render the page afterwards (``write_page``).

Sections that ``gym4real reproduce`` made after a baseline existed hold it already (it runs the protocol's
baselines, those its claims name and the upper references); this adds it to sections published before, without
training anything again.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from gym4real.bench.benchmark import benchmark
from gym4real.bench.versions import code_version
from gym4real.core.registry import baseline_names, non_causal
from gym4real.results import analysis
from gym4real.results.fingerprints import NOT_FOUND, section_changes
from gym4real.results.reproduce import episodes_table

#: The key of ``report.json`` that records the causal baselines added to a section (a list of records).
ADDED = "added_baselines"


def _blocking(changes: list[str]) -> list[str]:
    """The changes that make a section's test episodes incomparable: any but a training file not found here."""
    return [c for c in changes if not (c.startswith(("data.", "trainer.")) and c.endswith(NOT_FOUND))]


def _merge(episodes: pd.DataFrame, added: pd.DataFrame) -> pd.DataFrame:
    """``episodes`` with ``added``'s policies' rows: a policy measured before in its place, a new one at the end."""
    order = list(dict.fromkeys([*episodes["policy"], *added["policy"]]))
    new, parts = set(added["policy"]), []
    for policy in order:
        source = added if policy in new else episodes
        parts.append(source[source["policy"] == policy])
    merged = pd.concat(parts, ignore_index=True)
    merged["seed"] = merged["seed"].astype("Int64")
    return merged


def _record(report: dict[str, Any], policies: list[str], upper: bool, record: dict[str, Any]) -> None:
    """Record who measured ``policies`` in ``report``; an earlier record of one of them loses it."""
    if upper:
        report["upper_references"] = record
        return
    kept = []
    for earlier in report.get(ADDED, []):
        left = [p for p in earlier["policies"] if p not in policies]
        if left:
            kept.append({**earlier, "policies": left})
    report[ADDED] = [*kept, record]


def add(folder: Path, version: str | None = None, policies: Sequence[str] | None = None) -> str:
    """Add ``policies`` (default: the upper references) to one section; return what was done (or why not).

    ``version``: the code version that measures them (default :func:`code_version`; a run over several sections
    reads it once, before it writes into the first).
    """
    report_path = folder / "report.json"
    report = json.loads(report_path.read_text())
    env_id, budget = report["env_id"], report["budget"]
    upper = non_causal(env_id)
    wanted = list(dict.fromkeys(policies)) if policies else upper
    if not wanted:
        return f"{folder.name}: no upper reference registered for {env_id}"
    unknown = [p for p in wanted if p not in baseline_names(env_id)]
    if unknown:
        return f"{folder.name}: {unknown} not among the baselines of {env_id} ({', '.join(baseline_names(env_id))})"
    mixed = {p in upper for p in wanted}
    if len(mixed) > 1:
        return f"{folder.name}: add the upper references {upper} and causal baselines in separate runs"
    blocking = _blocking(section_changes(folder))
    if blocking:
        return f"{folder.name}: not current ({'; '.join(blocking)}): rerun it with `gym4real reproduce --stale`"
    start = time.perf_counter()
    result = benchmark(env_id, wanted, episodes="test")
    wall = time.perf_counter() - start
    episodes = pd.read_csv(folder / "episodes.csv")
    added = episodes_table(result, wanted, [])
    merged = _merge(episodes, added[[c for c in added.columns if c in episodes.columns]])
    merged.to_csv(folder / "episodes.csv", index=False)
    option = f"--policies {','.join(wanted)} " if policies else ""
    record = {
        "policies": wanted,
        "code_version": version or code_version(),
        "command": f"python scripts/add_upper_references.py {option}{folder.as_posix()}",
        "test_wall_time_s": wall,
    }
    _record(report, wanted, wanted[0] in upper, record)
    report_path.write_text(json.dumps(report, indent=1))
    analysis.analyse(folder, env_id, budget)
    return f"{folder.name}: added {', '.join(wanted)} ({len(added)} test episodes, {wall:.0f} s)"


def main(argv: Sequence[str] | None = None) -> int:
    """Add the policies; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="*", type=Path, help="section folders (default: docs/results/*-paper)")
    parser.add_argument(
        "--policies", default="", help="comma-separated registered baselines (default: the env's upper references)"
    )
    args = parser.parse_args(argv)
    sections = args.sections or sorted(p.parent for p in Path("docs/results").glob("*-paper/report.json"))
    policies = [p.strip() for p in args.policies.split(",") if p.strip()]
    version = code_version()  # before anything is written: the checkout's commit, not "dirty" with our output
    for folder in sections:
        print(add(folder, version, policies or None), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
