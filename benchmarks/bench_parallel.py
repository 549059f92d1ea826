"""Wall time of a quick reproduce plan with one job, two jobs, and on a local Ray instance.

    python benchmarks/bench_parallel.py [--envs gym4real/elevator-v0,gym4real/dam-v0] [--seeds 2]
        [--ray] [--json results/bench_parallel.json]
    python benchmarks/bench_parallel.py --command [--envs gym4real/dam-v0,gym4real/wds-v0,gym4real/trading-v0]
        [--seeds 4] [--repeats 3]

``--command`` times the whole ``gym4real reproduce --budget quick`` command as a user runs it (a fresh
process, the tests of each environment and the results page included) with ``--jobs 1`` and ``--jobs 2``,
alternately, ``--repeats`` times each, every time into a fresh folder; it reports each wall time, the
median ratio of ``--jobs 2`` to ``--jobs 1`` (the goal of issue 35: at most 0.85) and whether every CSV
the two wrote (the test episodes, every learning curve) is the same byte for byte.

Each executor trains the same plan (the quick budget's runs of ``--envs``, ``--seeds`` each) from scratch in
a fresh folder; the table gives its wall time, the speed-up over one job, and what each run cost beyond
its own training (the executor's wall time, times the workers, less the runs' summed training time, per
run: worker start-up, imports, numba compilation, Ray's scheduling and storage copies). The runs'
results are compared byte for byte with one job's. A shared machine's load changes every figure: say it
with them (the load average is printed).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).parent))

from report import report

from gym4real.bench.versions import available_cpus
from gym4real.results.plan import Item, plan
from gym4real.results.runner import THREAD_LIMITS, train_plan


def _same(a: Item, b: Item) -> bool:
    """The two runs wrote the same learning curve and the same model weights."""
    import zipfile

    import numpy as np

    if (a.folder / "curve.csv").read_bytes() != (b.folder / "curve.csv").read_bytes():
        return False
    if (a.folder / "qtable.npz").exists():
        return bool(np.array_equal(np.load(a.folder / "qtable.npz")["q"], np.load(b.folder / "qtable.npz")["q"]))
    with zipfile.ZipFile(a.folder / "model.zip") as za, zipfile.ZipFile(b.folder / "model.zip") as zb:
        return all(za.read(n) == zb.read(n) for n in ("policy.pth", "policy.optimizer.pth"))


def _measure(name: str, workers: int, items: list[Item], run: Any, baseline: list[Item] | None) -> dict[str, Any]:
    start = time.perf_counter()
    outcomes = run(items)
    wall = time.perf_counter() - start
    failed = [o.error for o in outcomes if o.run is None]
    if failed:
        raise SystemExit(f"{name}: {failed[0]}")
    training = sum(o.run.wall_time_s for o in outcomes if o.run is not None)
    return {
        "executor": name,
        "workers": workers,
        "runs": len(items),
        "wall_s": wall,
        "training_s": training,
        "overhead_per_run_s": (wall * workers - training) / len(items),
        "same_as_one_job": "-" if baseline is None else all(_same(a, b) for a, b in zip(baseline, items, strict=True)),
    }


#: ``--command``: the ratio of ``--jobs 2``'s wall time to ``--jobs 1``'s that issue 35 asks for at most.
COMMAND_GOAL = 0.85


def _csvs(out: Path) -> dict[str, bytes]:
    """The results of a reproduce folder that do not hold times: test episodes and learning curves, by path."""
    found = {}
    for path in sorted(out.rglob("*.csv")):
        if path.name in ("episodes.csv", "curve.csv"):
            found[str(path.relative_to(out))] = path.read_bytes()
    return found


def _reproduce(envs: list[str], seeds: int, jobs: int, out: Path) -> float:
    """Seconds of one ``gym4real reproduce --budget quick`` into ``out`` (a fresh process)."""
    import subprocess

    command = ["gym4real", "reproduce", *envs, "--budget", "quick", "--seeds", str(seeds), "--jobs", str(jobs)]
    start = time.perf_counter()
    subprocess.run([*command, "--out", str(out), "--quiet"], check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def command_rows(envs: list[str], seeds: int, repeats: int, root: Path) -> list[dict[str, Any]]:
    """``--command``: alternate ``--jobs 1`` and ``--jobs 2`` runs of the whole command, ``repeats`` each."""
    import statistics

    rows: list[dict[str, Any]] = []
    for r in range(repeats):
        walls = {jobs: _reproduce(envs, seeds, jobs, root / f"jobs{jobs}-{r}") for jobs in (1, 2)}
        same = _csvs(root / f"jobs1-{r}") == _csvs(root / f"jobs2-{r}")
        rows.append({"repeat": r, "jobs1_s": walls[1], "jobs2_s": walls[2], "ratio": walls[2] / walls[1]})
        rows[-1]["same_csvs"] = same and bool(_csvs(root / f"jobs1-{r}"))
    median = statistics.median(row["ratio"] for row in rows)
    rows.append(
        {
            "repeat": "median",
            "jobs1_s": statistics.median(row["jobs1_s"] for row in rows),
            "jobs2_s": statistics.median(row["jobs2_s"] for row in rows),
            "ratio": median,
            "same_csvs": f"{all(row['same_csvs'] for row in rows)}; goal <= {COMMAND_GOAL}: {median <= COMMAND_GOAL}",
        }
    )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", default="gym4real/elevator-v0,gym4real/dam-v0", help="comma-separated env ids")
    parser.add_argument("--seeds", type=int, default=2, help="seeds per algorithm")
    parser.add_argument("--ray", action="store_true", help="also on a local Ray instance (extra `cluster`)")
    parser.add_argument("--command", action="store_true", help="time the whole `gym4real reproduce` command")
    parser.add_argument("--repeats", type=int, default=3, help="--command: runs of each --jobs, alternately")
    parser.add_argument("--json", default=None, help="also save the rows as JSON")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench-parallel-"))
    if args.command:
        rows = command_rows(args.envs.split(","), args.seeds, args.repeats, root)
        load = os.getloadavg()
        print(f"gym4real reproduce {args.envs} --budget quick --seeds {args.seeds}; {available_cpus()} cores")
        print(f"load average at the end (1, 5, 15 min): {load[0]:.1f}, {load[1]:.1f}, {load[2]:.1f}\n")
        report(rows, ["repeat", "jobs1_s", "jobs2_s", "ratio", "same_csvs"], 3, args.json)
        return

    def items(name: str) -> list[Item]:
        return [i for env_id in args.envs.split(",") for i in plan(env_id, "quick", args.seeds, root / name)]

    one = items("one")
    rows = [_measure("--jobs 1", 1, one, lambda p: train_plan(p, jobs=1), None)]
    rows.append(_measure("--jobs 2", 2, items("two"), lambda p: train_plan(p, jobs=2), one))
    if args.ray:
        import ray

        from gym4real.results.cluster import train_on_ray

        start = time.perf_counter()
        ray.init(
            num_cpus=2,
            include_dashboard=False,
            log_to_driver=False,
            runtime_env={"env_vars": THREAD_LIMITS},
            _node_ip_address="127.0.0.1",  # this machine only
        )
        started = time.perf_counter() - start
        rows.append(_measure("--ray (2 CPUs)", 2, items("ray"), lambda p: train_on_ray(p, root / "ray"), one))
        rows[-1]["executor"] += f", ray.init {started:.1f} s"
        ray.shutdown()
    for row in rows[1:]:
        row["speed_up"] = rows[0]["wall_s"] / row["wall_s"]
    rows[0]["speed_up"] = 1.0
    load = os.getloadavg()
    print(f"plan: {args.envs}, quick budget, {args.seeds} seed(s): {len(one)} runs; {available_cpus()} cores")
    print(f"load average at the end (1, 5, 15 min): {load[0]:.1f}, {load[1]:.1f}, {load[2]:.1f}\n")
    cols = ["executor", "runs", "wall_s", "speed_up", "training_s", "overhead_per_run_s", "same_as_one_job"]
    report(rows, cols, 3, args.json)


if __name__ == "__main__":
    main()
