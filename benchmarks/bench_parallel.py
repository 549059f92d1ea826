"""Wall time of a quick reproduce plan with one job, two jobs, and on a local Ray instance.

    python benchmarks/bench_parallel.py [--envs gym4real/elevator-v0,gym4real/dam-v0] [--seeds 2]
        [--ray] [--json results/bench_parallel.json]

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

from gym4real.core.rl.plan import Item, plan
from gym4real.core.rl.runner import THREAD_LIMITS, available_cpus, train_plan


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", default="gym4real/elevator-v0,gym4real/dam-v0", help="comma-separated env ids")
    parser.add_argument("--seeds", type=int, default=2, help="seeds per algorithm")
    parser.add_argument("--ray", action="store_true", help="also on a local Ray instance (extra `cluster`)")
    parser.add_argument("--json", default=None, help="also save the rows as JSON")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench-parallel-"))

    def items(name: str) -> list[Item]:
        return [i for env_id in args.envs.split(",") for i in plan(env_id, "quick", args.seeds, root / name)]

    one = items("one")
    rows = [_measure("--jobs 1", 1, one, lambda p: train_plan(p, jobs=1), None)]
    rows.append(_measure("--jobs 2", 2, items("two"), lambda p: train_plan(p, jobs=2), one))
    if args.ray:
        import ray

        from gym4real.core.rl.cluster import train_on_ray

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
