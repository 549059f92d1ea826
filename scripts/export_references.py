"""Copy the paper-budget reference runs from the results page into the domain packages.

``python scripts/export_references.py [RESULTS] [--budget paper] [ENV_ID ...]`` reads, for each environment,
``RESULTS/<name>-<budget>/episodes.csv`` and ``manifest.json`` (written by ``gym4real reproduce``; RESULTS
defaults to ``docs/results``), takes the fingerprint of the installed environment's protocol, and writes
``packages/gym4real-<domain>/src/gym4real/<domain>/reference/<name>.csv`` and ``.json``, the files
``gym4real evaluate`` compares with (:mod:`gym4real.bench.reference`). Run it in an editable checkout,
after the paper-budget runs, with the data files at hand (the fingerprint makes each environment).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from gym4real.bench.reference import export_reference
from gym4real.core.errors import Gym4RealError
from gym4real.core.registry import list_envs, registry, slug


def main(argv: Sequence[str] | None = None) -> int:
    """Export the reference runs; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="?", default="docs/results", help="results folder (default docs/results)")
    parser.add_argument("env_ids", nargs="*", metavar="ENV_ID", help="environments (default: every one with results)")
    parser.add_argument("--budget", default="paper", help="budget of the runs (default paper)")
    parser.add_argument("--into", default=None, help="write here instead of the domain packages (to look first)")
    args = parser.parse_args(argv)
    results = Path(args.results)
    env_ids = args.env_ids or [
        e
        for e in list_envs(multi_objective=False)
        if e in registry().benchmarks and (results / f"{slug(e)}-{args.budget}" / "episodes.csv").is_file()
    ]
    if not env_ids:
        print(f"export_references: error: no `<env>-{args.budget}/episodes.csv` in `{results}`", file=sys.stderr)
        return 2
    for env_id in env_ids:
        try:
            print(f"wrote {export_reference(env_id, results, args.budget, args.into)}")
        except Gym4RealError as exc:
            print(f"export_references: error: {env_id}: {exc}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
