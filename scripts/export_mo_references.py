"""Measure and write the multi-objective reference point and rule-based fronts of the vector-reward ids.

``python scripts/export_mo_references.py [ENV_ID ...] [--measured CSV] [--into DIR]`` writes, for each id
(default: every vector-reward id whose domain declares its evaluation), ``packages/gym4real-<domain>/src/
gym4real/<domain>/reference/<name>.mo.json`` (:func:`gym4real.bench.mo_reference.export`): ``random``'s test
episodes (from the env's shipped reference runs, else run), the reference point they give, and every
rule-based sweep run on the test protocol. ``--measured`` takes per-episode objectives already measured on
the same protocol (columns ``env_id, policy, episode`` and one per objective; ``policy`` is ``random`` or
``<sweep>:<label>``), for a sweep too slow to run here. Run it in an editable checkout with the data files.

``--hindsight`` adds (or measures again) the ``hindsight`` front of each id's file instead
(:func:`gym4real.bench.mo_reference.add_front`): the domain's hindsight planner,
``gym4real.<domain>.hindsight:weighted_hindsight``, planning each test episode on the weighted objective,
with the raw weights that rank objective vectors as the EUM weight ``w`` does on the normalised scale
(``normalised=True``). ``--divisions D`` runs it at the ``D + 1`` weights ``k / D`` (two objectives; the
Das-Dennis lattice of ``D`` divisions in general) instead of the EUM's 50, for a planner too slow to run at
all of them; ``D = 7`` gives 8 weights that are all EUM weights (every 7th of ``k / 49``).
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
from collections.abc import Sequence

import numpy as np
import pandas as pd

from gym4real.bench import mo_metrics
from gym4real.bench.mo_reference import add_front, export, load
from gym4real.core.errors import ConfigError, Gym4RealError
from gym4real.core.mo_spec import mo_ids, mo_spec
from gym4real.core.registry import base_env, domain_of, load_object


def _measured(path: str | None, env_id: str) -> dict[str, np.ndarray]:
    if path is None:
        return {}
    frame = pd.read_csv(path)
    frame = frame[frame["env_id"] == env_id]
    names = list(mo_spec(env_id).names)
    return {
        policy: rows.sort_values("episode")[names].to_numpy(dtype=float) for policy, rows in frame.groupby("policy")
    }


def lattice(objectives: int, divisions: int) -> np.ndarray:
    """The Das-Dennis lattice of ``divisions`` divisions: every weight vector of entries ``k / divisions``."""
    return mo_metrics.simplex_weights(objectives, math.comb(divisions + objectives - 1, objectives - 1))


def hindsight_front(env_id: str, into: str | None, divisions: int | None, command: str) -> str:
    """Add the ``hindsight`` front to an id's file (measured again if there is one); its path."""
    domain = domain_of(base_env(env_id))
    factory = f"gym4real.{domain}.hindsight:weighted_hindsight"
    reference = load(env_id, into)
    if reference is None:
        raise ConfigError(f"`{env_id}` has no reference file yet: run this script without --hindsight first")
    eum = len(reference.weights)
    if divisions is None:
        weights, at = None, f"each of the {eum} EUM weights"
    else:
        weights = lattice(len(mo_spec(env_id).objectives), divisions)
        at = (
            f"{len(weights)} weights, the lattice of {divisions} divisions (a coarser grid than the EUM's {eum} "
            "weights, for the planner's CPU time: docs/headroom.md); the EUM is still over all its weights"
        )
    description = (
        f"non-causal upper reference: the hindsight planner `{factory}`, which knows each test episode's "
        "exogenous data, planning the weighted objective at weights w over the raw objectives that rank objective "
        f"vectors as the EUM weight does on the normalised scale (w_i / (top_i - reference_point_i)), run at {at}"
    )
    path = add_front(
        env_id,
        "hindsight",
        "hindsight",
        description,
        load_object(factory),
        folder=into,
        command=command,
        weights=weights,
        normalised=True,
        replace=True,
    )
    return str(path)


def main(argv: Sequence[str] | None = None) -> int:
    """Export the multi-objective references; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("env_ids", nargs="*", metavar="ENV_ID", help="vector-reward ids (default: every declared one)")
    parser.add_argument("--measured", default=None, help="CSV of per-episode objectives already measured")
    parser.add_argument("--into", default=None, help="write here instead of the domain packages (to look first)")
    parser.add_argument(
        "--hindsight", action="store_true", help="add the hindsight planner's weighted front to the existing files"
    )
    parser.add_argument(
        "--divisions", type=int, default=None, help="with --hindsight: run at the k / D weights, not the EUM's"
    )
    args = parser.parse_args(argv)
    if args.divisions is not None and (not args.hindsight or args.divisions < 1):
        parser.error("--divisions takes a positive number of divisions, with --hindsight")
    command = "python scripts/export_mo_references.py " + shlex.join(list(argv if argv is not None else sys.argv[1:]))
    for env_id in args.env_ids or mo_ids():
        try:
            if args.hindsight:
                wrote = hindsight_front(env_id, args.into, args.divisions, command.strip())
            else:
                wrote = str(export(env_id, args.into, _measured(args.measured, env_id), command.strip()))
            print(f"wrote {wrote}", flush=True)
        except Gym4RealError as exc:
            print(f"export_mo_references: error: {env_id}: {exc}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
