"""The ``gym4real`` command: list, info, bench, data, train, reproduce.

Errors are printed as one line (``gym4real: error: ...``) with exit status 2, never a traceback
(set ``GYM4REAL_DEBUG=1`` for one).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from gym4real.core.errors import Gym4RealError


def _cmd_list(args: argparse.Namespace) -> None:
    from gym4real.core.registry import list_envs, plugin_errors, registry

    for env_id in list_envs():
        print(f"{env_id:34s} {registry().envs[env_id].description}")
    for err in plugin_errors():
        print(f"(unavailable) {err}", file=sys.stderr)


def _cmd_info(args: argparse.Namespace) -> None:
    from gym4real.core.info import env_info

    print(json.dumps(asdict(env_info(args.env_id)), indent=2, default=str))


def _env_kwargs(pairs: Sequence[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep:
            raise Gym4RealError(f"`--env {pair}` must be KEY=VALUE (the value is read as JSON, else as text)")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


def _cmd_bench(args: argparse.Namespace) -> None:
    from gym4real.core.benchmark import benchmark

    episodes: int | str = int(args.episodes) if args.episodes.isdigit() else args.episodes
    policies = [p for p in args.policies.split(",") if p] if args.policies else None
    out = Path(args.out or Path("results") / args.env_id.replace("/", "_"))
    result = benchmark(
        args.env_id,
        policies,
        episodes=episodes,
        seed=args.seed,
        env_kwargs=_env_kwargs(args.env),
        progress=not args.quiet,
        out=out,
    )
    print(result.table())
    print(f"results and figures written to {out}/")


def _cmd_data(args: argparse.Namespace) -> None:
    from gym4real.core import datasets
    from gym4real.core.registry import registry

    if args.years:
        _fetch_years(args)
        return
    specs = [
        s
        for n, s in sorted(registry().datasets.items())
        if not args.names or any(n == k or n.startswith(k.rstrip("/") + "/") for k in args.names)
    ]
    if args.names and not specs:
        raise Gym4RealError(f"no dataset matches {args.names}; see `gym4real data list`")
    failed = []
    for spec in specs:
        if args.action == "list":
            print(f"{spec.name:40s} {spec.path:60s} {spec.licence}")
            continue
        try:
            path = datasets.resolve(spec.name, download=args.action == "fetch")
        except Gym4RealError as exc:
            failed.append(spec.name)
            print(f"FAIL {spec.name:40s} {' '.join(str(exc).split())}")
        else:
            print(f"ok   {spec.name:40s} {path}")
    if failed:
        raise Gym4RealError(f"{len(failed)} of {len(specs)} data files unavailable: {', '.join(failed)}")


def _fetch_years(args: argparse.Namespace) -> None:
    """Data a domain downloads by year from its own source (trading: HistData), via ``gym4real.<d>.fetch``."""
    import importlib

    if args.action != "fetch" or not args.names:
        raise Gym4RealError("`--years` goes with `gym4real data fetch DOMAIN --years Y [Y ...]`")
    for domain in args.names:
        try:
            module = importlib.import_module(f"gym4real.{domain}.fetch")
        except ModuleNotFoundError as exc:
            raise Gym4RealError(f"domain `{domain}` has no by-year download (no `gym4real.{domain}.fetch`)") from exc
        for path in module.fetch(args.years):
            print(f"ok   {path}")


def _cmd_train(args: argparse.Namespace) -> None:
    from gym4real.core.rl.train import train

    run = train(args.env_id, algo=args.algo, preset=args.preset, seed=args.seed, out=args.out, progress=not args.quiet)
    print(f"model written to {run.model_path}; learning curve in {run.curve_csv}")


def _cmd_reproduce(args: argparse.Namespace) -> None:
    from gym4real.core.registry import list_envs
    from gym4real.core.rl.reproduce import reproduce

    if bool(args.env_ids) == args.all:
        raise Gym4RealError("name the environments to reproduce, or pass --all (not both)")
    env_ids = list_envs() if args.all else args.env_ids
    print(reproduce(env_ids, args.budget, args.seeds, args.out, progress=not args.quiet, page=args.page))


def _cmd_dataset(args: argparse.Namespace) -> None:
    from gym4real.core.offline import collect

    path = collect(args.env_id, args.policy, args.episodes, args.out, seed=args.seed, env_kwargs=_env_kwargs(args.env))
    print(f"Minari dataset written to {path} (load it with MINARI_DATASETS_PATH={args.out})")


class _Versions(argparse.Action):
    """``--version``: every installed gym4real distribution and its version, then exit."""

    def __init__(self, option_strings: Sequence[str], dest: str, **kwargs: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, *args: Any) -> None:
        from gym4real.core.hookspecs import PLUGIN_API_VERSION
        from gym4real.core.registry import installed_distributions

        for name, version in installed_distributions():
            print(f"{name} {version}" + (f" (plugin API {PLUGIN_API_VERSION})" if name == "gym4real-core" else ""))
        parser.exit()


#: What the command trusts, printed under ``--help``.
TRUST = (
    "Trusted: the installed gym4real plugins (Python packages you installed). Data, never run as code: configs, "
    "presets, data files, and model files given as ppo:PATH, dqn:PATH, qlearning:PATH or sarsa:PATH (an SB3 zip "
    "is read without unpickling anything; a pickled entry SB3 does not write for PPO/DQN is refused)."
)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="gym4real", description="Realistic RL environments with the Gymnasium API.", epilog=TRUST
    )
    p.add_argument("--version", action=_Versions, help="list the installed gym4real distributions and exit")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the installed environments").set_defaults(run=_cmd_list)
    info = sub.add_parser("info", help="describe an environment")
    info.add_argument("env_id")
    info.set_defaults(run=_cmd_info)

    bench = sub.add_parser("bench", help="benchmark policies on an environment (table and figures)")
    bench.add_argument("env_id")
    bench.add_argument(
        "--policies",
        help="comma-separated baselines or kind:path models, read as data (default: the protocol's)",
    )
    bench.add_argument("--episodes", default="test", help='"test" (the paper protocol) or a number')
    bench.add_argument("--seed", type=int, default=0)
    bench.add_argument("--env", action="append", default=[], metavar="KEY=VALUE", help="make() keyword argument")
    bench.add_argument("--out", help="output folder (default results/<env>)")
    bench.add_argument("--quiet", action="store_true", help="no progress bar")
    bench.set_defaults(run=_cmd_bench)

    data = sub.add_parser("data", help="list, fetch or verify the data files")
    data.add_argument("action", choices=["list", "fetch", "verify"])
    data.add_argument("names", nargs="*", help="domains or dataset names (default: all)")
    data.add_argument("--years", nargs="+", type=int, help="years to download from a domain's own source (trading)")
    data.set_defaults(run=_cmd_data)

    train = sub.add_parser("train", help="train an RL agent with a registered preset or a YAML preset file")
    train.add_argument("env_id")
    train.add_argument("--algo", required=True)
    train.add_argument("--preset", default="paper", help="registered preset (paper, smoke) or a YAML file")
    train.add_argument("--seed", type=int, default=0)
    train.add_argument("--out", default=None)
    train.add_argument("--quiet", action="store_true")
    train.set_defaults(run=_cmd_train)

    rep = sub.add_parser(
        "reproduce", help="train the paper's agents over seeds, test them beside the baselines, check the claims"
    )
    rep.add_argument("env_ids", nargs="*", metavar="ENV_ID")
    rep.add_argument("--all", action="store_true", help="every installed environment")
    rep.add_argument("--budget", choices=["paper", "quick"], default="paper", help="paper settings, or minutes")
    rep.add_argument("--seeds", type=int, default=None, help="seeds per algorithm (default: the paper's)")
    rep.add_argument("--out", default="results/reproduce", help="output folder; finished runs there are reused")
    rep.add_argument("--page", default=None, help="also write the results page and figures into this folder")
    rep.add_argument("--quiet", action="store_true")
    rep.set_defaults(run=_cmd_reproduce)
    dataset = sub.add_parser("dataset", help="offline-RL datasets")
    dsub = dataset.add_subparsers(dest="dataset_command", required=True)
    collect = dsub.add_parser("collect", help="write episodes of a policy as a Minari dataset")
    collect.add_argument("env_id")
    collect.add_argument("--policy", required=True, help="a baseline name or kind:path model")
    collect.add_argument("--episodes", type=int, default=10)
    collect.add_argument("--seed", type=int, default=0)
    collect.add_argument("--env", action="append", default=[], metavar="KEY=VALUE", help="make() keyword argument")
    collect.add_argument("--out", required=True, help="folder of the Minari datasets")
    collect.set_defaults(run=_cmd_dataset)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    args = _parser().parse_args(argv)
    run: Callable[[argparse.Namespace], None] = args.run
    try:
        run(args)
    except (Gym4RealError, OSError, ValueError, KeyError) as exc:
        if os.environ.get("GYM4REAL_DEBUG"):
            raise
        msg = " ".join(str(exc).split())
        print(f"gym4real: error: {msg}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
