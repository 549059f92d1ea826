"""``gym4real dataset collect``: episodes of a policy as a Minari dataset (offline RL)."""

from __future__ import annotations

import argparse
from typing import Any

from gym4real.cli.common import ENV_ID_HELP, command, env_kwargs


def _collect(args: argparse.Namespace) -> None:
    from gym4real.offline import collect

    path = collect(args.env_id, args.policy, args.episodes, args.out, seed=args.seed, env_kwargs=env_kwargs(args.env))
    print(f"Minari dataset written to {path} (load it with MINARI_DATASETS_PATH={args.out})")


def add(sub: Any) -> None:
    """``dataset collect``."""
    dataset = sub.add_parser("dataset", help="offline-RL datasets", description="Offline-RL datasets.")
    dsub = dataset.add_subparsers(dest="dataset_command", required=True, metavar="COMMAND")
    collect = command(dsub, "collect", "write episodes of a policy as a Minari dataset", _collect)
    collect.add_argument("env_id", help=ENV_ID_HELP)
    collect.add_argument("--policy", required=True, help="a baseline name or kind:path model")
    collect.add_argument("--episodes", type=int, default=10, help="number of episodes (default 10)")
    collect.add_argument("--seed", type=int, default=0, help="seed of the first episode, +1 for each next one")
    collect.add_argument("--env", action="append", default=[], metavar="KEY=VALUE", help="make() keyword argument")
    collect.add_argument("--out", required=True, help="folder of the Minari datasets")
