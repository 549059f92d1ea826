"""Measure and write the multi-objective reference point and rule-based fronts of the vector-reward ids.

``python scripts/export_mo_references.py [ENV_ID ...] [--measured CSV] [--into DIR]`` writes, for each id
(default: every vector-reward id whose domain declares its evaluation), ``packages/gym4real-<domain>/src/
gym4real/<domain>/reference/<name>.mo.json`` (:func:`gym4real.bench.mo_reference.export`): ``random``'s test
episodes (from the env's shipped reference runs, else run), the reference point they give, and every
rule-based sweep run on the test protocol. ``--measured`` takes per-episode objectives already measured on
the same protocol (columns ``env_id, policy, episode`` and one per objective; ``policy`` is ``random`` or
``<sweep>:<label>``), for a sweep too slow to run here. Run it in an editable checkout with the data files.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Sequence

import numpy as np
import pandas as pd

from gym4real.bench.mo_reference import export
from gym4real.core.errors import Gym4RealError
from gym4real.core.mo_spec import mo_ids, mo_spec


def _measured(path: str | None, env_id: str) -> dict[str, np.ndarray]:
    if path is None:
        return {}
    frame = pd.read_csv(path)
    frame = frame[frame["env_id"] == env_id]
    names = list(mo_spec(env_id).names)
    return {
        policy: rows.sort_values("episode")[names].to_numpy(dtype=float) for policy, rows in frame.groupby("policy")
    }


def main(argv: Sequence[str] | None = None) -> int:
    """Export the multi-objective references; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("env_ids", nargs="*", metavar="ENV_ID", help="vector-reward ids (default: every declared one)")
    parser.add_argument("--measured", default=None, help="CSV of per-episode objectives already measured")
    parser.add_argument("--into", default=None, help="write here instead of the domain packages (to look first)")
    args = parser.parse_args(argv)
    command = "python scripts/export_mo_references.py " + shlex.join(list(argv if argv is not None else sys.argv[1:]))
    for env_id in args.env_ids or mo_ids():
        try:
            print(f"wrote {export(env_id, args.into, _measured(args.measured, env_id), command.strip())}", flush=True)
        except Gym4RealError as exc:
            print(f"export_mo_references: error: {env_id}: {exc}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
