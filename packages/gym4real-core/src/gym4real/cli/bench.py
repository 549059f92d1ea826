"""``gym4real bench``: policies on an environment's test protocol, a table and figures."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from gym4real.cli.common import ENV_ID_HELP, command, env_kwargs, user_code_importable


def _bench(args: argparse.Namespace) -> None:
    from gym4real.bench.benchmark import benchmark
    from gym4real.bench.reference import published_lines
    from gym4real.core.registry import slug

    user_code_importable()
    episodes: int | str = int(args.episodes) if args.episodes.isdigit() else args.episodes
    policies = [p for p in args.policies.split(",") if p] if args.policies else None
    out = Path(args.out or Path("results") / slug(args.env_id))
    result = benchmark(
        args.env_id,
        policies,
        episodes=episodes,
        seed=args.seed,
        env_kwargs=env_kwargs(args.env),
        progress=not args.quiet,
        out=out,
    )
    print(result.table())
    if result.test_protocol and not args.env:  # the paper's agents beside, on the protocol they were tested on
        print("\n".join(["", *published_lines(args.env_id)]))
    print(f"results and figures written to {out}/")


def add(sub: Any) -> None:
    """``bench``."""
    bench = command(sub, "bench", "benchmark policies on an environment (table and figures)", _bench, extra="bench")
    bench.add_argument("env_id", help=ENV_ID_HELP)
    bench.add_argument(
        "--policies",
        help="comma-separated baselines, kind:path models (read as data: ppo:PATH, sb3:a2c:PATH, ...) or your own "
        "module:attr factories (imported and run) (default: the protocol's)",
    )
    bench.add_argument("--episodes", default="test", help='"test" (the paper protocol, default) or a number')
    bench.add_argument("--seed", type=int, default=0, help="seed of the first episode when --episodes is a number")
    bench.add_argument("--env", action="append", default=[], metavar="KEY=VALUE", help="make() keyword argument")
    bench.add_argument(
        "--out", help="folder of the table, CSV, JSON and figures (default results/<env>: results/dam-v0)"
    )
    bench.add_argument("--quiet", action="store_true", help="no progress bar")
