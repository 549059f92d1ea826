"""``gym4real reproduce``: the paper's agents over seeds beside the baselines, the results page, its currency."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from gym4real.cli.common import ENV_ID_HELP, command, jobs, seeds_of
from gym4real.core.errors import Gym4RealError


def _reproduce(args: argparse.Namespace) -> None:
    from gym4real.core.registry import list_envs
    from gym4real.results.reproduce import reproduce
    from gym4real.results.run_files import DamagedRunError

    if args.check is not None:
        from gym4real.results.currency import check

        found = check(args.check)
        print("\n".join(found.lines))
        found.raise_for_outcome()
        return
    if args.stale:
        from gym4real.results.currency import reproduce_stale

        print(reproduce_stale(Path(args.out), args.env_ids, args.seeds, page=args.page, jobs=args.jobs))
        return
    if bool(args.env_ids) == args.all:
        raise Gym4RealError("name the environments to reproduce, or pass --all (not both)")
    env_ids = list_envs(multi_objective=False) if args.all else args.env_ids
    n_seeds = seeds_of(args.seeds)
    if args.storage and not args.ray:
        raise Gym4RealError("--storage is where Ray workers keep the run folders: pass it with --ray")
    if args.plan:
        from gym4real.results.estimate import plan_report

        print(plan_report(env_ids, args.budget, n_seeds, Path(args.out), args.jobs))
        return
    try:
        text = reproduce(
            env_ids,
            args.budget,
            n_seeds,
            args.out,
            progress=not args.quiet,
            page=args.page,
            jobs=args.jobs,
            ray=args.ray,
            storage=args.storage,
            retrain_damaged=args.retrain_damaged,
            trainer=args.trainer,
        )
    except DamagedRunError as exc:  # the other runs and the page are done: show them, then the error
        print(exc.report)
        raise
    print(text)


def add(sub: Any) -> None:
    """``reproduce``."""
    from gym4real.bench.seeds import SEEDS_HELP

    rep = command(
        sub,
        "reproduce",
        "train the paper's agents over seeds, test them beside the baselines, check the paper's claims",
        _reproduce,
        extra="bench",
    )
    rep.add_argument("env_ids", nargs="*", metavar="ENV_ID", help=f"{ENV_ID_HELP} (several allowed)")
    rep.add_argument(
        "--all",
        action="store_true",
        help="every installed environment (not the vector-reward -mo ids: they train nothing)",
    )
    rep.add_argument(
        "--budget",
        choices=["paper", "quick"],
        default="paper",
        help="paper: the appendix's settings (hours); quick: the smoke presets (minutes, checks the pipeline)",
    )
    rep.add_argument(
        "--seeds",
        default=None,
        metavar="N|a,b,c",
        help=f"{SEEDS_HELP} (default: the paper's, at least 5 at the paper budget; quick: 2 at most)",
    )
    rep.add_argument("--out", default="results/reproduce", help="output folder; finished runs there are reused")
    rep.add_argument("--page", default=None, help="also write the results page and figures into this folder")
    rep.add_argument("--quiet", action="store_true", help="no progress bar")
    rep.add_argument(
        "--check",
        default=None,
        metavar="DIR",
        help="say per results section of DIR (an output or page folder) whether it is current with this code "
        "(its protocol, data and trainer fingerprints), stale (what changed) or not checkable here (the data it read "
        "is missing here: the command that brings it, and its cost), and check every file of DIR against the SHA-256 "
        "of manifest.json and models.json (missing, changed and unknown files and missing sections, by name). Exit "
        "status: 0 all current and every file as listed; 5 a file or section damaged (whatever else); 3 a section "
        "stale; 4 a section not checkable here (and none stale); 2 DIR cannot be checked",
    )
    rep.add_argument(
        "--stale",
        action="store_true",
        help="rerun only the stale sections of --out (of the named environments, if any): retrain where the "
        "data or trainer changed, else test the finished runs again",
    )
    rep.add_argument(
        "--trainer",
        default="sb3",
        choices=("sb3", "jax"),
        help="sb3 (the reference trainer) or jax: the budget's PPO runs by the JAX trainer (the `jax` extra), in "
        "sections of their own (<env>-<budget>-jax, agent ppo-jax)",
    )
    rep.add_argument(
        "--retrain-damaged",
        action="store_true",
        help="move a run folder with a damaged file aside (<folder>.damaged-<time>) and train that run again",
    )
    rep.add_argument(
        "--jobs",
        type=jobs,
        default=1,
        metavar="N|auto",
        help="training runs at a time, each in a worker process (auto: one per available core; default 1)",
    )
    rep.add_argument(
        "--ray",
        action="store_true",
        help="run the training runs on Ray (extra `cluster`): the cluster RAY_ADDRESS names, else a local instance",
    )
    rep.add_argument(
        "--storage",
        default=None,
        metavar="URI",
        help="with --ray: where workers keep run folders and checkpoints (a path, NFS, s3://...; default --out)",
    )
    rep.add_argument(
        "--plan",
        action="store_true",
        help="print the plan, each run's estimated CPU time and the wall time for --jobs workers, and exit",
    )
