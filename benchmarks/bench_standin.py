"""Cost of the microgrid stand-in (`gym4real data synthesize microgrid`): per household, and the whole command.

    python benchmarks/bench_standin.py [--households 20] [--json results/bench_standin.json]
    python benchmarks/bench_standin.py --command [--jobs 2] [--json results/bench_standin_command.json]

The first form times households of the default seed in this process: the first one (it loads the compiled
model, or compiles it the first time) and ``--households`` more, each in CPU seconds (the figure
``gym4real.microgrid.data.SECONDS_PER_HOUSEHOLD`` quotes; richardsonpy alone takes about 21 s).

``--command`` runs the whole command as a user runs it: a fresh process, ``--jobs`` workers, the paper's
370 households, into a fresh cache folder (``GYM4REAL_CACHE_DIR``). From its progress lines it reports when
the first household and the last were done, the time to write the CSV after them and the wall time, and
whether the file is the published stand-in byte for byte. A shared machine's load changes every wall time:
the load average is printed with them.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).parent))

from report import report

from gym4real.core.datasets import sha256_of
from gym4real.microgrid import standin


def _households(count: int) -> list[dict[str, Any]]:
    rows = []
    for index in range(count + 1):
        start = time.process_time()
        standin.household(index)
        cpu = time.process_time() - start
        rows.append({"household": index, "size": standin.household_size(index, standin.SEED), "cpu_s": cpu})
    first, rest = rows[0], [r["cpu_s"] for r in rows[1:]]
    print(f"first household (loads or compiles the model): {first['cpu_s']:.2f} s of CPU")
    print(f"{count} more: median {statistics.median(rest):.3f} s, mean {statistics.mean(rest):.3f} s of CPU each")
    return rows


def progress_seconds(stderr: str) -> list[float]:
    """The elapsed seconds of each progress line of ``gym4real data synthesize microgrid`` (not on a terminal)."""
    line = r"^synthesize microgrid: \d+/\d+ households \((?:\d+ %, )?(\d+) s\)$"
    return [float(s) for s in re.findall(line, stderr, re.M)]


def _command(jobs: int) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "GYM4REAL_CACHE_DIR": cache}
        args = ["gym4real", "data", "synthesize", "microgrid", "--jobs", str(jobs)]
        load = os.getloadavg()[0]
        start = time.perf_counter()
        done = subprocess.run(args, env=env, capture_output=True, text=True, check=True)
        wall = time.perf_counter() - start
        marks = progress_seconds(done.stderr)
        digest = sha256_of(Path(cache) / standin.PATH)
    print(done.stderr.splitlines()[0])
    return {
        "jobs": jobs,
        "first_household_s": marks[0],
        "households_s": marks[-1],
        "write_s": wall - marks[-1],
        "wall_s": wall,
        "load_before": load,
        "load_after": os.getloadavg()[0],
        "published_bytes": digest == standin.PUBLISHED["sha256"],
        "sha256": digest[:12],
    }


def main() -> None:
    """Print the households' CPU times, or the whole command's wall time."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--households", type=int, default=20, help="households timed after the first")
    parser.add_argument("--command", action="store_true", help="time the whole command in a fresh process")
    parser.add_argument("--jobs", type=int, default=2, help="--command: worker processes")
    parser.add_argument("--json", default=None, help="also save the rows as JSON")
    args = parser.parse_args()
    if args.command:
        cols = ["jobs", "first_household_s", "households_s", "write_s", "wall_s", "load_before", "load_after"]
        report([_command(args.jobs)], [*cols, "published_bytes", "sha256"], 3, args.json)
    else:
        report(_households(args.households), ["household", "size", "cpu_s"], 3, args.json)


if __name__ == "__main__":
    main()
