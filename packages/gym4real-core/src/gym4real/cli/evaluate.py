"""``gym4real evaluate``: your agent on the test protocols beside the reference runs, with a suite score."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from gym4real.cli.common import command, seeds_of, user_code_importable
from gym4real.core.errors import Gym4RealError


def _evaluate(args: argparse.Namespace) -> None:
    from gym4real.bench.evaluate import evaluate

    if bool(args.envs) == args.all:
        raise Gym4RealError("name the environments with --envs ID,ID, or pass --all (not both)")
    user_code_importable()
    agents: dict[str, str] = {}
    for policy in args.policies:
        name, sep, ref = policy.partition("=")
        name, ref = (name, ref) if sep and ":" not in name else (policy, policy)
        agents[name] = ref
    envs: str | list[str] = "all" if args.all else [e for e in args.envs.split(",") if e]
    seeds = seeds_of(args.seeds)
    if args.mo:  # the policies form sets (one per NAME), or a NAME is a weight-conditioned factory
        from gym4real.bench.mo_eval import agents_of, evaluate_mo

        # the -mo ids train nothing, so no plan names their seeds: N is 0, 1, ..., N - 1
        mo_seeds = list(range(seeds)) if isinstance(seeds, int) else seeds
        found = evaluate_mo(agents_of(args.policies), envs, mo_seeds, args.references, args.out, args.episode_timeout)
        print(found.table())
        print(f'score.json (its "mo" section), mo_episodes.csv and Pareto plots written to {args.out}/')
        return
    result = evaluate(
        agents,
        envs,
        seeds=seeds,
        references=args.references,
        out=args.out,
        allow_non_causal=args.allow_non_causal,
        headroom=not args.no_headroom,
        episode_timeout=args.episode_timeout,
    )
    print(result.table())
    print(f"score.json, CSVs, figures and report.md written to {args.out}/")


def add(sub: Any) -> None:
    """``evaluate``."""
    from gym4real.bench.seeds import SEEDS_HELP

    ev = command(
        sub,
        "evaluate",
        "score your agent on the test protocols beside the reference runs (per env and a suite score)",
        _evaluate,
        extra="bench",
    )
    ev.add_argument(
        "policies",
        nargs="+",
        metavar="POLICY",
        help="[NAME=]POLICY: your module:attr factory or policy (imported and run), sb3:ALGO:PATH (any SB3 or "
        "sb3-contrib algorithm), ppo:PATH, ..., or a baseline; {env} and {seed} in it are replaced by the env name "
        "and the seed",
    )
    ev.add_argument("--envs", help="comma-separated environment ids")
    ev.add_argument("--all", action="store_true", help="every installed environment with a test protocol")
    ev.add_argument(
        "--seeds",
        metavar="N|a,b,c",
        help=f"your agent's training seeds: {SEEDS_HELP} (a factory is called as factory(env, seed=S))",
    )
    ev.add_argument("--references", help="folder of reference files to use instead of those the domains ship")
    ev.add_argument(
        "--mo",
        action="store_true",
        help="multi-objective: on vector-reward ids (--all: every one), the POLICYs named alike form one agent's set "
        "(a module:attr list gives its items; a module:attr factory(env, weights, seed) is run at each EUM weight); "
        "hypervolume and EUM against the shipped reference point and fronts",
    )
    ev.add_argument("--out", default=str(Path("results") / "evaluate"), help="output folder (default results/evaluate)")
    ev.add_argument(
        "--allow-non-causal",
        action="store_true",
        help="accept a non-causal upper reference (hindsight, which knows the episode's exogenous data) as an agent",
    )
    ev.add_argument(
        "--episode-timeout",
        type=float,
        metavar="SECONDS",
        help="stop an agent that takes longer than this for one test episode, with an error naming where (default: "
        "no limit)",
    )
    ev.add_argument(
        "--no-headroom",
        action="store_true",
        help="do not run the upper references the reference runs lack (no shortfall from hindsight where missing)",
    )
