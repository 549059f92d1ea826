"""The ``gym4real`` command: list, info, bench, record, data, train, reproduce, evaluate.

Errors are printed as one line (``gym4real: error: ...``) with exit status 2, never a traceback
(set ``GYM4REAL_DEBUG=1`` for one).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
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
    from gym4real.core.info import summary, summary_text

    record = summary(args.env_id)
    print(json.dumps(record, indent=2, default=str) if args.json else summary_text(record))


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


def _user_code_importable() -> None:
    """Let ``module:attr`` policies name modules of the working folder, as ``python -m`` would."""
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())


def _cmd_bench(args: argparse.Namespace) -> None:
    from gym4real.core.benchmark import benchmark
    from gym4real.core.rl.plan import slug

    _user_code_importable()
    episodes: int | str = int(args.episodes) if args.episodes.isdigit() else args.episodes
    policies = [p for p in args.policies.split(",") if p] if args.policies else None
    out = Path(args.out or Path("results") / slug(args.env_id))
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


def _cmd_record(args: argparse.Namespace) -> None:
    import warnings

    from gym4real.core.record import NoMp4Warning, record

    _user_code_importable()
    with warnings.catch_warnings(record=True) as caught:  # each warning of the recording said in one line
        warnings.simplefilter("always", NoMp4Warning)
        paths = record(
            args.env_id,
            args.policy,
            episodes=args.episodes,
            seed=args.seed,
            out=args.out,
            fps=args.fps,
            env_kwargs=_env_kwargs(args.env),
            max_steps=args.max_steps,
            mp4=not args.no_mp4,
            gif_frames=args.gif_frames,
            progress=not args.quiet,
        )
    for warning in caught:
        print(f"gym4real: warning: {warning.message}", file=sys.stderr)
    for path in paths:
        print(f"wrote {path}")


def _add_record(sub: Any) -> None:
    rec = _command(sub, "record", "write videos (MP4 and animated GIF) of a policy's episodes", _cmd_record)
    rec.add_argument("env_id", help=ENV_ID_HELP)
    rec.add_argument("--policy", required=True, help="a baseline name or kind:path model (ppo:runs/x/model.zip)")
    rec.add_argument("--episodes", type=int, default=1, help="episodes, seeded seed, seed + 1, ...")
    rec.add_argument("--seed", type=int, default=0, help="seed of the first episode (default 0)")
    rec.add_argument("--out", default=str(Path("results") / "videos"), help="output folder (default results/videos)")
    rec.add_argument("--fps", type=float, default=None, help="frames per second (default the env's render_fps)")
    rec.add_argument("--env", action="append", default=[], metavar="KEY=VALUE", help="make() keyword argument")
    rec.add_argument("--max-steps", type=int, default=None, help="cut each episode after this many steps")
    rec.add_argument("--gif-frames", type=int, default=100, help="most frames in the GIF (evenly spaced steps)")
    rec.add_argument("--no-mp4", action="store_true", help="write the GIF only (no MoviePy needed)")
    rec.add_argument("--quiet", action="store_true", help="no progress bar")


def _cmd_data(args: argparse.Namespace) -> None:
    from gym4real.core import data_command

    if args.years:
        _fetch_years(args)
        return
    if args.action == "synthesize":
        _synthesize(args)
        return
    data_command.run(args.action, args.names, args.urls)


def _synthesize(args: argparse.Namespace) -> None:
    """A domain's stand-in for data published nowhere we can reach (microgrid), via ``gym4real.<d>.standin``."""
    from gym4real.core.datasets import cache_dir, standin_module

    if len(args.names) != 1:
        raise Gym4RealError("name one domain: `gym4real data synthesize microgrid`")
    domain = args.names[0]
    module = standin_module(domain)
    if module is None:
        raise Gym4RealError(f"domain `{domain}` has no stand-in data (no `gym4real.{domain}.standin`)")
    kwargs = {k: getattr(args, k) for k in ("households", "seed") if getattr(args, k) is not None}
    module.check_tools()  # a missing tool is said before anything is drawn or written
    households = kwargs.get("households", module.HOUSEHOLDS)
    print(
        f"synthesizing {households} households of {domain} with {args.jobs} job(s): "
        f"{module.expected_time(households, args.jobs)} (households already written are reused)",
        file=sys.stderr,
    )
    bar = None
    if not args.quiet:
        from tqdm.auto import tqdm

        bar = tqdm(desc=f"synthesize {domain}", unit="household")

    def progress(done: int, total: int) -> None:
        if bar is not None:
            bar.total = total
            bar.update(done - bar.n)

    path = module.synthesize(cache_dir() / module.PATH, jobs=args.jobs, progress=progress, **kwargs)
    if bar is not None:
        bar.close()
    print(f"ok   {path} (provenance and SHA-256 in {path.with_suffix('.json').name})")


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
    from gym4real.core.rl.run_files import DamagedRunError

    if args.check is not None:
        from gym4real.core.rl.currency import StaleResultsError, check

        lines, stale = check(args.check)
        print("\n".join(lines))
        if stale:
            raise StaleResultsError(
                f"{len(stale)} of {len(lines)} sections are stale ({', '.join(stale)}): rerun them with "
                f"`gym4real reproduce --stale --out OUT` on the output folder they came from"
            )
        return
    if args.stale:
        from gym4real.core.rl.currency import reproduce_stale

        print(reproduce_stale(Path(args.out), args.env_ids, args.seeds, page=args.page, jobs=args.jobs))
        return
    if bool(args.env_ids) == args.all:
        raise Gym4RealError("name the environments to reproduce, or pass --all (not both)")
    env_ids = list_envs(multi_objective=False) if args.all else args.env_ids
    n_seeds = _seeds(args.seeds)
    if args.storage and not args.ray:
        raise Gym4RealError("--storage is where Ray workers keep the run folders: pass it with --ray")
    if args.plan:
        from gym4real.core.rl.estimate import plan_report

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
        )
    except DamagedRunError as exc:  # the other runs and the page are done: show them, then the error
        print(exc.report)
        raise
    print(text)


def _jobs(text: str) -> int:
    """``--jobs``: a positive number, or ``auto`` (the cores available to this process)."""
    from gym4real.core.rl.runner import available_cpus

    if text == "auto":
        return available_cpus()
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a positive number of jobs or `auto`, not `{text}`")
    return int(text)


def _seeds(text: str | None) -> int | list[int] | None:
    """``--seeds`` of ``reproduce`` and ``evaluate``: one meaning (:data:`~gym4real.core.rl.plan.SeedRequest`)."""
    from gym4real.core.rl.plan import parse_seeds

    return None if text is None else parse_seeds(text)


def _cmd_evaluate(args: argparse.Namespace) -> None:
    from gym4real.core.evaluate import evaluate

    if bool(args.envs) == args.all:
        raise Gym4RealError("name the environments with --envs ID,ID, or pass --all (not both)")
    _user_code_importable()
    agents: dict[str, str] = {}
    for policy in args.policies:
        name, sep, ref = policy.partition("=")
        name, ref = (name, ref) if sep and ":" not in name else (policy, policy)
        agents[name] = ref
    envs: str | list[str] = "all" if args.all else [e for e in args.envs.split(",") if e]
    seeds = _seeds(args.seeds)
    if args.mo:  # the policies form sets (one per NAME), or a NAME is a weight-conditioned factory
        from gym4real.core.mo_eval import agents_of, evaluate_mo

        # the -mo ids train nothing, so no plan names their seeds: N is 0, 1, ..., N - 1
        mo_seeds = list(range(seeds)) if isinstance(seeds, int) else seeds
        found = evaluate_mo(agents_of(args.policies), envs, mo_seeds, args.references, args.out)
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
    )
    print(result.table())
    print(f"score.json, CSVs, figures and report.md written to {args.out}/")


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
    "Trusted: the installed gym4real plugins (Python packages you installed), and your own code that you name as a "
    "policy `module:attr` (it is imported and run, like a plugin). Data, never run as code: configs, presets, data "
    "files, reference runs, and model files given as ppo:PATH, dqn:PATH, sb3:ALGO:PATH, qlearning:PATH or "
    "sarsa:PATH (an SB3 zip is read without unpickling anything; a pickled entry SB3 does not write for its "
    "algorithm is refused)."
)


ENV_ID_HELP = "an installed environment id, e.g. gym4real/elevator-v0 (`gym4real list` shows them)"


def _command(sub: Any, name: str, text: str, run: Callable[[argparse.Namespace], None]) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = sub.add_parser(name, help=text, description=text[0].upper() + text[1:] + ".")
    parser.set_defaults(run=run)
    return parser


def _parser() -> argparse.ArgumentParser:
    from gym4real.core.rl.plan import SEEDS_HELP
    from gym4real.core.rl.presets import ALGOS

    p = argparse.ArgumentParser(
        prog="gym4real", description="Realistic RL environments with the Gymnasium API.", epilog=TRUST
    )
    p.add_argument("--version", action=_Versions, help="list the installed gym4real distributions and exit")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _command(sub, "list", "list the installed environments", _cmd_list)
    info = _command(
        sub, "info", "describe an environment: flags, spaces, episode end, presets, baselines, data", _cmd_info
    )
    info.add_argument("env_id", help=ENV_ID_HELP)
    info.add_argument("--json", action="store_true", help="print the record as JSON (for programs)")

    bench = _command(sub, "bench", "benchmark policies on an environment (table and figures)", _cmd_bench)
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
    _add_record(sub)

    data = _command(sub, "data", "list, fetch or verify the data files", _cmd_data)
    data.add_argument(
        "action",
        choices=["list", "fetch", "verify", "synthesize"],
        help="list: where each file is; fetch: download the missing ones; verify: check each copy's SHA-256; "
        "synthesize: write a domain's documented stand-in for data that is not published (microgrid: the "
        "training households) into the user cache",
    )
    data.add_argument("names", nargs="*", help="domains or dataset names (default: all)")
    data.add_argument("--years", nargs="+", type=int, help="years to download from a domain's own source (trading)")
    data.add_argument("--urls", action="store_true", help="add each file's path and upstream address to the table")
    data.add_argument("--households", type=int, default=None, help="synthesize: number of households (default 370)")
    data.add_argument("--seed", type=int, default=None, help="synthesize: seed of the stand-in (default: the domain's)")
    data.add_argument("--jobs", type=int, default=1, help="synthesize: worker processes")
    data.add_argument("--quiet", action="store_true", help="synthesize: no progress bar")

    train = _command(sub, "train", "train an RL agent with a registered preset or a YAML preset file", _cmd_train)
    train.add_argument("env_id", help=ENV_ID_HELP)
    train.add_argument("--algo", required=True, choices=ALGOS, help=f"algorithm: {', '.join(ALGOS)}")
    train.add_argument("--preset", default="paper", help="registered preset (paper, smoke) or a YAML file")
    train.add_argument("--seed", type=int, default=0, help="seed of the run (default 0)")
    train.add_argument(
        "--out",
        default=None,
        help="output folder (default runs/<env>/<algo>-<preset>-seed<S>: runs/dam-v0/ppo-paper-seed0)",
    )
    train.add_argument("--quiet", action="store_true", help="no progress bar")

    rep = _command(
        sub,
        "reproduce",
        "train the paper's agents over seeds, test them beside the baselines, check the paper's claims",
        _cmd_reproduce,
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
        "(its protocol, data and trainer fingerprints) or stale, and what changed; exit 0 only when all are current",
    )
    rep.add_argument(
        "--stale",
        action="store_true",
        help="rerun only the stale sections of --out (of the named environments, if any): retrain where the "
        "data or trainer changed, else test the finished runs again",
    )
    rep.add_argument(
        "--retrain-damaged",
        action="store_true",
        help="move a run folder with a damaged file aside (<folder>.damaged-<time>) and train that run again",
    )
    rep.add_argument(
        "--jobs",
        type=_jobs,
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

    ev = _command(
        sub,
        "evaluate",
        "score your agent on the test protocols beside the reference runs (per env and a suite score)",
        _cmd_evaluate,
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
        "--no-headroom",
        action="store_true",
        help="do not run the upper references the reference runs lack (no shortfall from hindsight where missing)",
    )

    dataset = sub.add_parser("dataset", help="offline-RL datasets", description="Offline-RL datasets.")
    dsub = dataset.add_subparsers(dest="dataset_command", required=True, metavar="COMMAND")
    collect = _command(dsub, "collect", "write episodes of a policy as a Minari dataset", _cmd_dataset)
    collect.add_argument("env_id", help=ENV_ID_HELP)
    collect.add_argument("--policy", required=True, help="a baseline name or kind:path model")
    collect.add_argument("--episodes", type=int, default=10, help="number of episodes (default 10)")
    collect.add_argument("--seed", type=int, default=0, help="seed of the first episode, +1 for each next one")
    collect.add_argument("--env", action="append", default=[], metavar="KEY=VALUE", help="make() keyword argument")
    collect.add_argument("--out", required=True, help="folder of the Minari datasets")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    args = _parser().parse_args(argv)
    run: Callable[[argparse.Namespace], None] = args.run
    try:
        run(args)
    except BrokenPipeError:  # the reader went away (`gym4real list | head`): nothing left to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # so that the exit flush is quiet
        return 0
    except (Gym4RealError, OSError, ValueError, KeyError) as exc:
        if os.environ.get("GYM4REAL_DEBUG"):
            raise
        msg = " ".join(str(exc).split())
        print(f"gym4real: error: {msg}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
