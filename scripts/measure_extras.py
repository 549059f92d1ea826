"""Measure what each extra of ``gym4real-core`` adds to an install (the README's table of extras).

Each install gets its own fresh venv under ``DIR``: ``DIR/core`` holds ``./packages/gym4real-core`` alone and
``DIR/<extra>`` holds ``./packages/gym4real-core[<extra>]``, installed with ``pip install --no-compile`` (so no
bytecode is counted). An extra whose resolution brings torch gets the CPU build of torch first, from
:data:`TORCH_INDEX`, as the comment on core's ``rl`` extra tells a user to do. A venv that exists already is
measured as it is, so a second run only prints.

The size of an install is the sum, over its distributions, of the files each one's ``RECORD`` lists (as found
on disk), the venv's own pip and setuptools left out. What an extra adds is its venv's size less the thin
core's; its biggest distributions are those it brings or replaces (another version than core's), by the
bytes each adds (a replacement: its size less the replaced one's), largest first.

Usage: ``nice python scripts/measure_extras.py DIR [--extras rl,jax] [--jobs 2] [--json out.json]``
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tomllib
import venv
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "packages" / "gym4real-core"
#: Where the CPU build of torch comes from (a plain ``torch`` on Linux is a multi-GB CUDA build).
TORCH_INDEX = "https://download.pytorch.org/whl/cpu"
#: A venv's own seed distributions, not part of any install measured here.
SEEDS = {"pip", "setuptools"}
#: Run in the measured venv's interpreter: each distribution's name, version and bytes of its RECORD's files.
SIZES = """
import json, re
from importlib.metadata import distributions
out = {}
for dist in distributions():
    name = re.sub(r"[-_.]+", "-", dist.metadata["Name"]).lower()
    size = sum(p.stat().st_size for p in (dist.locate_file(f) for f in dist.files or ()) if p.is_file())
    out[name] = [dist.version, size]
print(json.dumps(out))
"""


@dataclass(frozen=True)
class Added:
    """What one extra adds to the thin core: bytes, distributions brought or replaced, and the bytes each adds."""

    extra: str
    size: int
    count: int
    biggest: list[tuple[str, str, int]]

    def cells(self, top: int = 3) -> str:
        """The table's ``adds | mostly`` cells: sizes in MB (10**6 bytes), the ``top`` biggest (none under 0.5 MB)."""
        big = [(name, size) for name, _, size in self.biggest if size >= 0.5e6][:top]
        mostly = ", ".join(f"{name} {size / 1e6:.0f} MB" for name, size in big)
        return f"{self.size / 1e6:.0f} MB ({self.count} distributions) | {mostly}"


def extras() -> list[str]:
    """The extras ``packages/gym4real-core/pyproject.toml`` declares, in its order."""
    with (CORE / "pyproject.toml").open("rb") as file:
        return list(tomllib.load(file)["project"]["optional-dependencies"])


def _pip(where: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """Run the venv's pip; a failure raises with pip's own output."""
    done = subprocess.run(
        [str(where / "bin" / "python"), "-m", "pip", *args], capture_output=True, text=True, check=False
    )
    if done.returncode:
        raise RuntimeError(f"pip {' '.join(args)} failed in {where}:\n{done.stdout[-3000:]}{done.stderr[-3000:]}")
    return done


def create(where: Path, extra: str | None) -> Path:
    """A fresh venv at ``where`` with core (and ``extra``) installed; an existing venv is left as it is."""
    if (where / "bin" / "python").exists():
        return where
    spec = f"{CORE}[{extra}]" if extra else str(CORE)
    venv.create(where, with_pip=True)
    report = json.loads(_pip(where, "install", "--dry-run", "--quiet", "--report", "-", spec).stdout)
    if any(item["metadata"]["name"].lower() == "torch" for item in report["install"]):
        _pip(where, "install", "--no-compile", "torch", "--index-url", TORCH_INDEX)
    _pip(where, "install", "--no-compile", spec)
    return where


def sizes(where: Path) -> dict[str, tuple[str, int]]:
    """Each distribution of the venv at ``where`` (its seeds left out): name -> (version, installed bytes)."""
    done = subprocess.run([str(where / "bin" / "python"), "-c", SIZES], capture_output=True, text=True, check=True)
    return {name: (v, s) for name, (v, s) in json.loads(done.stdout).items() if name not in SEEDS}


def added(extra: str, core: dict[str, tuple[str, int]], full: dict[str, tuple[str, int]]) -> Added:
    """What ``full`` (core with ``extra``) holds beyond ``core``."""
    brought = sorted(
        (
            (name, version, size - core.get(name, ("", 0))[1])
            for name, (version, size) in full.items()
            if core.get(name, ("", 0))[0] != version
        ),
        key=lambda item: -item[2],
    )
    total = sum(size for _, size in full.values()) - sum(size for _, size in core.values())
    return Added(extra, total, len(brought), brought)


def main(argv: list[str] | None = None) -> int:
    """Make the missing venvs, measure them and print the table's rows (``| `extra` | adds | mostly |``)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path, help="folder of the venvs (made where missing, reused where present)")
    parser.add_argument("--extras", help="comma-separated extras to measure (default: every declared one)")
    parser.add_argument("--jobs", type=int, default=2, help="installs at once (default 2)")
    parser.add_argument("--json", type=Path, help="also write every distribution's size here")
    args = parser.parse_args(argv)
    declared = extras()
    chosen = args.extras.split(",") if args.extras else declared
    unknown = sorted(set(chosen) - set(declared))
    if unknown:
        parser.error(
            f"--extras: {', '.join(unknown)} not declared in {CORE / 'pyproject.toml'} ({', '.join(declared)})"
        )
    args.root.mkdir(parents=True, exist_ok=True)
    core = sizes(create(args.root / "core", None))
    print(f"core: {sum(s for _, s in core.values()) / 1e6:.0f} MB, {len(core)} distributions", flush=True)
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        venvs = dict(zip(chosen, pool.map(lambda e: create(args.root / e, e), chosen), strict=True))
    rows = {extra: added(extra, core, sizes(where)) for extra, where in venvs.items()}
    for extra, row in rows.items():
        print(f"| `{extra}` | {row.cells()} |")
    if args.json:
        args.json.write_text(json.dumps({"core": core, **{e: r.biggest for e, r in rows.items()}}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
