"""``gym4real data list|fetch|verify|synthesize``: the registered data files as one table, a summary and the fix.

``list`` looks for a copy of each file (no hashing), ``verify`` checks each copy's SHA-256, ``fetch``
downloads the missing ones and stops asking a host after it could not be reached once. A file that is
absent but whose domain's stand-in is present (``gym4real data synthesize``) is listed as ``stand-in``,
where the stand-in lies: it is what the domain reads in the file's place.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlsplit

from gym4real.cli.common import command, jobs
from gym4real.core import datasets
from gym4real.core.errors import DataUnreachableError, Gym4RealError
from gym4real.core.specs import DatasetSpec


@dataclass(frozen=True)
class Row:
    """One data file in the table: its spec, status and the copy found (``where`` is empty if none)."""

    spec: DatasetSpec
    status: str
    size: int | None = None
    where: str = ""


def select(names: Sequence[str]) -> list[DatasetSpec]:
    """The registered data files named by ``names`` (domains, folders or full names; all when empty)."""
    specs = [
        spec
        for name, spec in sorted(datasets.registry().datasets.items())
        if not names or any(name == k or name.startswith(k.rstrip("/") + "/") for k in names)
    ]
    if names and not specs:
        raise Gym4RealError(f"no data file matches {' '.join(names)}; `gym4real data list` shows them all")
    return specs


def _row(spec: DatasetSpec, verify: bool) -> Row:
    copy = datasets.find(spec.name)
    if copy is None:
        module = datasets.stand_in_replacing(spec.name)
        stand_in = datasets.find_stand_in(module.PATH) if module is not None else None
        if stand_in is not None:  # read in the file's place (it has no registered hash to verify)
            return Row(spec, "stand-in", stand_in.path.stat().st_size, f"{stand_in.where} ({stand_in.path.name})")
        return Row(spec, "missing")
    status = ("ok" if datasets.is_intact(spec, copy.path) else "corrupt") if verify else "present"
    return Row(spec, status, copy.path.stat().st_size, copy.where)


def _fetch(specs: Sequence[DatasetSpec]) -> tuple[list[Row], dict[str, str]]:
    """Download the missing files; a host that cannot be reached is not asked again (its files are skipped)."""
    rows, dead = [], {}
    for spec in specs:
        host = urlsplit(spec.url).hostname or spec.url
        row = _row(spec, verify=True)
        if row.status in ("ok", "stand-in"):  # a stand-in is read in the place of a file published nowhere we reach
            rows.append(row)
        elif host in dead:
            rows.append(Row(spec, "skipped"))
        else:
            print(f"downloading {spec.name} from {host}", file=sys.stderr, flush=True)
            try:
                path = datasets.resolve(spec.name, download=True)
            except DataUnreachableError as exc:
                dead[host] = exc.cause
                rows.append(Row(spec, "failed"))
            except Gym4RealError:
                rows.append(Row(spec, "failed"))
            else:
                rows.append(Row(spec, "fetched", path.stat().st_size, "user cache"))
    return rows, dead


def size_text(size: int | None) -> str:
    """``1234567`` -> ``1.2 MB`` (decimal units); ``-`` for no size."""
    if size is None:
        return "-"
    value = float(size)
    for unit in ("B", "kB", "MB"):
        if value < 1000:
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1000
    return f"{value:.1f} GB"


def table(rows: Sequence[Row], urls: bool = False) -> str:
    """The rows as a fixed-width table with a header (and the upstream address of each file if ``urls``)."""
    cells = [("name", "size", "status", "found in", *(["path", "upstream address"] if urls else []))]
    for r in rows:
        cells.append((r.spec.name, size_text(r.size), r.status, r.where or "-", *([r.spec.path, r.spec.url] * urls)))
    widths = [max(len(c[i]) for c in cells) for i in range(len(cells[0]))]
    return "\n".join(
        "  ".join(
            f"{c:{'>' if i == 1 else '<'}{w}}" for i, (c, w) in enumerate(zip(line, widths, strict=True))
        ).rstrip()
        for line in cells
    )


def places_text() -> str:
    """The folders searched, one line, each with the setting that gave it."""
    parts = [f"{where} = {folder}" for where, folder in datasets.places()]
    if not os.environ.get(datasets.DATA_DIR_ENV):
        parts.insert(0, f"{datasets.DATA_DIR_ENV} not set")
    return "searched: " + "; ".join(parts)


def _fix(rows: Sequence[Row], action: str, dead: dict[str, str]) -> str:
    missing = [r for r in rows if r.status in ("missing", "failed", "skipped")]
    corrupt = [r for r in rows if r.status == "corrupt"]
    fixes = []
    if missing:
        domains = " ".join(sorted({r.spec.name.split("/")[0] for r in missing}))
        folders = Counter(datasets.upstream_folder(r.spec) for r in missing)
        held = [f"a copy of {f} holds {n} of them" for f, n in sorted(folders.items(), key=str) if f]
        fixes.append(
            f"set {datasets.DATA_DIR_ENV} to a folder holding the missing files at their paths "
            f"({'; '.join([*held, '`gym4real data list --urls` gives the upstream address of each'])})"
        )
        if not dead and action != "fetch":  # an unreachable host: fetching again from here cannot help
            fixes.append(f"run `gym4real data fetch {domains}` to download them")
    for r in corrupt:
        fixes.append(f"replace `{r.spec.path}` in {r.where} with the upstream file {r.spec.url}")
    return "Fix: " + "; or ".join(fixes) + "." if fixes else ""


def summary(rows: Sequence[Row], dead: dict[str, str]) -> str:
    """One line: how many files, how many here (and their size), which are missing or corrupt."""
    here = [r for r in rows if r.size is not None]
    text = f"{len(rows)} data files: {len(here)} here ({size_text(sum(r.size or 0 for r in here))})"
    for status in ("fetched", "corrupt", "missing", "failed", "skipped"):
        named = [r.spec.name for r in rows if r.status == status]
        if named:
            text += f", {len(named)} {status} ({', '.join(named[:4])}{', ...' if len(named) > 4 else ''})"
    for host, cause in dead.items():
        text += f"; {host} cannot be reached ({cause}): no further file was asked of it"
    return text


def run(action: str, names: Sequence[str], urls: bool = False) -> None:
    """Print the table of ``action`` (list, fetch or verify) over the selected files (with addresses if ``urls``).

    Raises:
        Gym4RealError: ``fetch`` or ``verify`` left a file missing or corrupt (the summary and the fix).
    """
    specs = select(names)
    dead: dict[str, str] = {}
    if action == "fetch":
        rows, dead = _fetch(specs)
    else:
        rows = [_row(spec, verify=action == "verify") for spec in specs]
    print(table(rows, urls))
    for row in rows:
        if row.spec.stand_in_for:
            print(f"{row.spec.name} is a stand-in for {row.spec.stand_in_for}")
    print(places_text())
    line, fix = summary(rows, dead), _fix(rows, action, dead)
    if action != "list" and fix:
        raise Gym4RealError(f"{line}. {fix}")
    print(line)
    if fix:
        print(fix)


def _data(args: argparse.Namespace) -> None:
    if args.years:
        _fetch_years(args)
        return
    if args.action == "synthesize":
        _synthesize(args)
        return
    run(args.action, args.names, args.urls)


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
    out = cache_dir() / module.PATH
    print(
        f"writing {module.DESCRIPTION} of {domain} to {out}: {households} households with {args.jobs} worker "
        f"process(es), {module.expected_time(households, args.jobs)} (households already written are reused)",
        file=sys.stderr,
    )
    from gym4real.bench.progress import ProgressDisplay

    shown = None if args.quiet else ProgressDisplay(f"synthesize {domain}", unit="households")
    path = module.synthesize(out, jobs=args.jobs, progress=shown.update if shown else None, **kwargs)
    if shown is not None:
        shown.close()
    digest = datasets.sha256_of(path)
    print(f"ok   {path} (SHA-256 {digest}; provenance in {path.with_suffix('.json').name})")
    published = module.PUBLISHED
    if (households, kwargs.get("seed", published["seed"])) == (published["households"], published["seed"]):
        if digest == published["sha256"]:
            print("     the published stand-in, byte for byte (the one docs/results' runs trained on)")
        else:
            print(
                f"warning: the published stand-in's SHA-256 is {published['sha256']}: this file differs (another "
                "version of richardsonpy or numpy?); runs trained on it are not comparable with docs/results'",
                file=sys.stderr,
            )


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


def add(sub: Any) -> None:
    """``data``."""
    data = command(sub, "data", "list, fetch or verify the data files", _data)
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
    data.add_argument(
        "--jobs",
        type=jobs,
        default="auto",
        metavar="N|auto",
        help="synthesize: worker processes (auto, the default: one per available core)",
    )
    data.add_argument("--quiet", action="store_true", help="synthesize: no progress output")
